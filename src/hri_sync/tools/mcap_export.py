"""``report --export mcap``: a session's bag as MCAP, for Foxglove and
PlotJuggler (docs/viewers.md). No ROS.

Every message of the bag is copied as it was recorded: the same ROS 1
bytes, each bag connection's own message definition as its schema
(``ros1msg``), the bag (receipt) time as the MCAP log and publish time.
Nothing is converted, so the MCAP holds what the bag holds, seq numbers
and md5sums included. Written with the ``mcap`` library (PyPI; rosbags
writes MCAP only as ROS 2 bags, converting every message).

Derived channels, so that a viewer plots every figure of the layouts in
``config/layouts`` against a header stamp (listed in the MCAP's
``hri_sync`` metadata record):

- ``/viewers/<client>/clock`` (``hri_sync_viewers/ClockStateStamped``): a
  ``/<client>/clock_state`` (which has no header) with ``header.stamp`` =
  the global time of its ``local_ref`` (``local_ref + offset``); a state
  without a model (not ok, or not finite) has no global time and is left
  out (counted in ``McapExport.skipped``);
- ``/viewers/<client>/client_result``: ``/client_result`` split by
  ``client_id`` (same type, same bytes); results recorded before they had
  a header (``bag.PRE_HEADER``) have no stamp to plot and are left out
  (counted).

The file is written to ``<name>.mcap.part`` and renamed to ``<name>.mcap``
only once complete and synced: an export that fails (a full disk, a read
error) removes its part file and raises McapError saying so; one that is
killed leaves only ``<name>.mcap.part`` (the next export replaces it and
says so). The bag is only read, and an MCAP already there is replaced only
by a complete one.
"""
import json
import math
import os
import struct
from dataclasses import dataclass, field

from hri_sync.tools.bag import BagError, _check_readable

PART = '.part'
VIEWERS = '/viewers'
CLOCK_TYPE = 'hri_sync_viewers/ClockStateStamped'
HEADER_DEF = ('uint32 seq\ntime stamp\nstring frame_id\n')
CLOCK_DEF = (
    '# A ClockState with header.stamp = the global time of its local_ref\n'
    '# (local_ref + offset); made by hri_sync report --export mcap.\n'
    'std_msgs/Header header\nstring client_id\nbool ok\nfloat64 local_ref\n'
    'float64 offset\nfloat64 drift\nfloat64 uncertainty\nuint32 samples\n'
    'float64 round_trip\n'
    + '=' * 80 + '\nMSG: std_msgs/Header\n' + HEADER_DEF)


class McapError(Exception):
    """An MCAP that could not be written, and what was left."""


@dataclass
class McapExport:
    """What an export wrote."""

    path: str
    messages: int = 0                   # copied from the bag
    channels: int = 0                   # of them
    derived: dict = field(default_factory=dict)   # topic -> messages
    skipped: dict = field(default_factory=dict)   # reason -> messages
    replaced_part: bool = False          # a killed export's part was there
    topics: list = field(default_factory=list)    # every channel's topic
    clocks: list = field(default_factory=list)    # clients with a clock
    participants: list = field(default_factory=list)  # decision order


def mcap_path(bag_path, out_dir=None):
    """``X.bag`` -> ``X.mcap`` (in ``out_dir`` if given)."""
    base = os.path.basename(bag_path)
    for ext in ('.active', '.bag'):
        if base.endswith(ext):
            base = base[:-len(ext)]
    folder = out_dir if out_dir else os.path.dirname(bag_path)
    return os.path.join(folder, base + '.mcap')


def ros_type(msgtype):
    """rosbags' ``pkg/msg/Name`` as ROS 1's ``pkg/Name``."""
    return msgtype.replace('/msg/', '/')


def _string(s):
    b = s.encode('utf-8')
    return struct.pack('<I', len(b)) + b


def clock_stamped(msg, seq):
    """ROS 1 bytes of a ClockStateStamped of ClockState ``msg``, or None
    when it has no global time (no model)."""
    stamp = msg.local_ref + msg.offset
    if not (msg.ok and math.isfinite(stamp) and stamp > 0):
        return None
    sec = int(math.floor(stamp))
    nsec = min(int(round((stamp - sec) * 1e9)), 999999999)
    return (struct.pack('<III', seq, sec, nsec) + _string('')
            + _string(msg.client_id) + struct.pack('<?', bool(msg.ok))
            + struct.pack('<ddddId', msg.local_ref, msg.offset, msg.drift,
                          msg.uncertainty, msg.samples,
                          getattr(msg, 'round_trip', math.nan)))


def _client_of(topic):
    """'left' of '/left/clock_state'."""
    return topic.strip('/').rsplit('/', 1)[0] or 'unknown'


class _Channels:
    """MCAP schemas and channels, one per (topic, type, md5, latching)."""

    def __init__(self, writer):
        self.writer = writer
        self.schemas, self.channels = {}, {}

    def schema(self, name, definition):
        if name not in self.schemas:
            self.schemas[name] = self.writer.register_schema(
                name=name, encoding='ros1msg',
                data=definition.encode('utf-8'))
        return self.schemas[name]

    def channel(self, topic, name, definition, md5='', latching=False):
        key = (topic, name, md5, latching)
        if key not in self.channels:
            meta = {'md5sum': md5} if md5 else {}
            if latching:
                meta['latching'] = '1'
            self.channels[key] = self.writer.register_channel(
                topic=topic, message_encoding='ros1',
                schema_id=self.schema(name, definition), metadata=meta)
        return self.channels[key]


def _derive(result, chans, conn, msg, t_ns, raw, seqs, write):
    """Write the derived messages of one bag message."""
    topic = '/' + conn.topic.lstrip('/')
    kind = ros_type(conn.msgtype)
    if kind == 'hri_sync/ClockState' and topic.endswith('/clock_state'):
        out = '%s/%s/clock' % (VIEWERS, _client_of(topic))
        data = clock_stamped(msg, seqs.get(out, 0))
        if data is None:
            _count(result.skipped, 'clock state without a model')
            return
        cid = chans.channel(out, CLOCK_TYPE, CLOCK_DEF)
    elif kind == 'hri_sync/ClientResult' and not hasattr(msg, 'header'):
        _count(result.skipped, 'result recorded without a header')
        return
    elif kind == 'hri_sync/ClientResult' and msg.client_id:
        out = '%s/%s/client_result' % (VIEWERS, msg.client_id.strip('/'))
        data = raw
        cid = chans.channel(out, kind, conn.msgdef.data, conn.digest)
    else:
        if kind == 'hri_sync/Decision' and not result.participants:
            result.participants = [c.strip('/') for c in msg.clients]
        return
    write(cid, t_ns, data, seqs.get(out, 0))
    _count(seqs, out)
    _count(result.derived, out)


def _count(counts, key):
    counts[key] = counts.get(key, 0) + 1


def _copy(reader, writer, result):
    """Every bag message into ``writer``, with the derived channels."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore
    store, registered = get_typestore(Stores.ROS1_NOETIC), set()
    chans, seqs = _Channels(writer), {}
    wanted = ('hri_sync/ClockState', 'hri_sync/ClientResult',
              'hri_sync/Decision')

    def write(cid, t_ns, data, seq):
        writer.add_message(channel_id=cid, log_time=t_ns, publish_time=t_ns,
                           data=data, sequence=seq & 0xffffffff)

    for conn, t_ns, raw in reader.messages():
        topic = '/' + conn.topic.lstrip('/')
        cid = chans.channel(topic, ros_type(conn.msgtype), conn.msgdef.data,
                            conn.digest, bool(conn.ext.latching))
        write(cid, t_ns, raw, result.messages)
        result.messages += 1
        if ros_type(conn.msgtype) not in wanted:
            continue
        if conn.msgtype not in registered:
            store.register(get_types_from_msg(conn.msgdef.data,
                                              conn.msgtype))
            registered.add(conn.msgtype)
        msg = store.deserialize_ros1(raw, conn.msgtype)
        _derive(result, chans, conn, msg, t_ns, raw, seqs, write)
    result.channels = len(chans.channels)
    result.topics = sorted({key[0] for key in chans.channels})
    result.clocks = [t.split('/')[2] for t in result.topics
                     if t.startswith(VIEWERS) and t.endswith('/clock')]
    if not result.participants:
        result.participants = [t.split('/')[2] for t in result.topics
                               if t.startswith(VIEWERS)
                               and t.endswith('/client_result')]


def write_mcap(bag_path, dst=None, opener=open):
    """Write the MCAP of ``bag_path`` to ``dst`` (default ``mcap_path``);
    returns an McapExport. Raises BagError for a bag that cannot be read
    (see ``bag``) and McapError when the MCAP cannot be written, after
    removing its part file. ``opener(path, mode)`` opens the part file
    (tests inject a failing one)."""
    try:
        from mcap.writer import CompressionType, Writer
    except ImportError:
        raise McapError('writing MCAP needs the Python library mcap: pip '
                        'install mcap (make setup installs it)')
    from rosbags.rosbag1 import Reader, ReaderError
    _check_readable(bag_path)
    dst = dst or mcap_path(bag_path)
    part = dst + PART
    result = McapExport(dst, replaced_part=os.path.exists(part))
    try:
        with Reader(bag_path) as reader, opener(part, 'wb') as f:
            writer = Writer(f, compression=CompressionType.ZSTD)
            writer.start(profile='ros1', library='hri_sync report')
            _copy(reader, writer, result)
            writer.add_metadata('hri_sync', {
                'bag': os.path.basename(bag_path),
                'messages': str(result.messages),
                'derived': json.dumps(result.derived, sort_keys=True),
                'skipped': json.dumps(result.skipped, sort_keys=True)})
            writer.finish()
            f.flush()
            os.fsync(f.fileno())
        os.replace(part, dst)
    except (OSError, ReaderError, ValueError, struct.error) as e:
        _remove(part)
        raise McapError(
            'writing %s failed after %d of the bag\'s messages: %s. '
            'Removed the partial %s; %s was only read%s' % (
                dst, result.messages, e, part, bag_path,
                '; the MCAP already there is kept' if os.path.exists(dst)
                else ''))
    return result


def _remove(path):
    try:
        os.remove(path)
    except OSError:     # never created, or already gone
        pass


def summary(export):
    """One line on what ``export`` wrote."""
    line = '%d messages on %d channels in %s, derived: %s' % (
        export.messages, export.channels, export.path,
        ', '.join('%s %d' % kv for kv in sorted(export.derived.items()))
        or 'none')
    if export.skipped:
        line += '; not derived: ' + ', '.join(
            '%d %s' % (n, why) for why, n in sorted(export.skipped.items()))
    if export.replaced_part:
        line += ('; replaced %s%s left by an interrupted export'
                 % (os.path.basename(export.path), PART))
    return line


__all__ = ['BagError', 'McapError', 'McapExport', 'mcap_path', 'write_mcap',
           'summary', 'clock_stamped']
