// Reads an hri_sync MCAP (report --export mcap) with Foxglove's own
// libraries: the MCAP reader (@mcap/core), the ROS 1 .msg parser
// (@foxglove/rosmsg) and deserializer (@foxglove/rosmsg-serialization),
// and prints the header stamps and values of a few plotted series and the
// number of messages decoded. Not part of make test (npm packages; ES
// modules resolve them from the script's folder, so copy it there):
//   mkdir /tmp/fox && cd /tmp/fox && npm install @mcap/core \
//       @foxglove/rosmsg @foxglove/rosmsg-serialization fzstd
//   cp test/system/mcap_foxglove_decode.mjs /tmp/fox && \
//       node /tmp/fox/mcap_foxglove_decode.mjs session.mcap
// docs/viewers.md has its output on test/bags/session_still.bag's MCAP.
import { McapIndexedReader } from "@mcap/core";
import { parse } from "@foxglove/rosmsg";
import { MessageReader } from "@foxglove/rosmsg-serialization";
import { decompress } from "fzstd";
import { open } from "node:fs/promises";

const path = process.argv[2];
const fh = await open(path, "r");
const readable = {
  size: async () => BigInt((await fh.stat()).size),
  read: async (offset, length) => {
    const buf = new Uint8Array(Number(length));
    await fh.read(buf, 0, Number(length), Number(offset));
    return buf;
  },
};
const reader = await McapIndexedReader.Initialize({
  readable,
  decompressHandlers: { zstd: (buf, size) => decompress(buf, new Uint8Array(Number(size))) },
});
const readers = new Map();
const counts = {};
const want = ["/viewers/left/clock", "/viewers/right/client_result", "/decision", "/left/captured"];
for await (const msg of reader.readMessages()) {
  const ch = reader.channelsById.get(msg.channelId);
  const schema = reader.schemasById.get(ch.schemaId);
  if (!readers.has(ch.id)) {
    if (schema.encoding !== "ros1msg" || ch.messageEncoding !== "ros1") throw new Error("encoding " + schema.encoding);
    readers.set(ch.id, new MessageReader(parse(new TextDecoder().decode(schema.data), { ros2: false })));
  }
  const m = readers.get(ch.id).readMessage(msg.data);
  counts[ch.topic] = (counts[ch.topic] ?? 0) + 1;
  if (want.includes(ch.topic) && counts[ch.topic] <= 2) {
    const v = ch.topic.endsWith("/clock") ? ["offset", m.offset, "uncertainty", m.uncertainty]
      : ch.topic === "/decision" ? ["scores", Array.from(m.scores)]
      : ch.topic.endsWith("client_result") ? ["first_frame_offset", m.first_frame_offset, "value", m.value]
      : ["client_id", m.client_id];
    console.log(ch.topic, "header.stamp", m.header.stamp.sec + "." + String(m.header.stamp.nsec).padStart(9, "0"), ...v);
  }
}
console.log("messages decoded:", Object.values(counts).reduce((a, b) => a + b, 0), "on", Object.keys(counts).length, "topics");
