"""Test helpers: copy a bag with edits, write the layout of a killed
recorder (rosbags; no ROS)."""
import dataclasses
import math
import struct

import numpy as np

from rosbags.rosbag1 import Reader, Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore


def copy_bag(src, dst, edit=None, md5=None, rename=None):
    """Copy ``src`` to ``dst``. ``edit(topic, t_ns, msg)`` returns the
    message to write (changed in place is fine), or None to drop it;
    ``md5``: {type ('pkg/Name'): md5} to record instead of the real one;
    ``rename(topic)``: the topic name to record instead."""
    store = get_typestore(Stores.ROS1_NOETIC)
    with Reader(src) as reader, Writer(dst) as writer:
        conns = {}
        for c in reader.connections:
            if c.msgtype not in store.types:
                store.register(get_types_from_msg(c.msgdef.data, c.msgtype))
            kind = c.msgtype.replace('/msg/', '/')
            conns[c.id] = writer.add_connection(
                rename(c.topic) if rename else c.topic, c.msgtype,
                msgdef=c.msgdef.data,
                md5sum=(md5 or {}).get(kind, c.digest),
                callerid=c.ext.callerid, latching=c.ext.latching)
        for c, t, raw in reader.messages():
            if edit is not None:
                msg = edit(c.topic, t, store.deserialize_ros1(raw, c.msgtype))
                if msg is None:
                    continue
                raw = store.serialize_ros1(msg, c.msgtype)
            writer.write(conns[c.id], t, raw)


def _header(fields):
    body = b''
    for k, v in fields.items():
        item = k.encode() + b'=' + v
        body += struct.pack('<I', len(item)) + item
    return struct.pack('<I', len(body)) + body


def write_unclosed(src, dst, until_ns):
    """Write the messages of ``src`` before ``until_ns`` as a recorder
    killed at that instant leaves them: a bag header with no index
    (index_pos 0) and one uncompressed chunk whose size was never filled
    in, its connection and message records running to the end of the
    file (the layout of test/bags/killed_recorder.bag.active)."""
    with open(dst, 'wb') as f, Reader(src) as reader:
        f.write(b'#ROSBAG V2.0\n')
        head = _header({'index_pos': struct.pack('<Q', 0),
                        'conn_count': struct.pack('<I', 0),
                        'chunk_count': struct.pack('<I', 0),
                        'op': b'\x03'})
        f.write(head)
        pad = 4096 - len(head) - 4
        f.write(struct.pack('<I', pad) + b' ' * pad)
        f.write(_header({'compression': b'none',
                         'size': struct.pack('<I', 0), 'op': b'\x05'}))
        f.write(struct.pack('<I', 0))
        seen = set()
        for c, t, raw in reader.messages():
            if t >= until_ns:
                break
            if c.id not in seen:
                seen.add(c.id)
                f.write(_header({'conn': struct.pack('<I', c.id),
                                 'topic': c.topic.encode(), 'op': b'\x07'}))
                data = {'topic': c.topic.encode(),
                        'type': c.msgtype.replace('/msg/', '/').encode(),
                        'md5sum': c.digest.encode(),
                        'message_definition': c.msgdef.data.encode()}
                if c.ext.callerid:
                    data['callerid'] = c.ext.callerid.encode()
                if c.ext.latching is not None:
                    data['latching'] = str(c.ext.latching).encode()
                f.write(_header(data))   # data_len + fields
            f.write(_header({'conn': struct.pack('<I', c.id),
                             'time': struct.pack('<II', t // 10 ** 9,
                                                 t % 10 ** 9),
                             'op': b'\x02'}))
            f.write(struct.pack('<I', len(raw)) + bytes(raw))
        # The record being written when the recorder died, cut short.
        f.write(struct.pack('<I', 4096)[:3])


def appended(store, msgtype, fields):
    """Zero values of the fields of ``msgtype`` in ``store`` missing from
    ``fields`` (fields appended to a definition since: ActionStart's)."""
    zero = {'str': '', 'float': 0.0, 'int': 0, 'bool': False}
    out = {}
    for f in dataclasses.fields(store.types[msgtype]):
        kind = str(f.type)
        if f.name not in fields and not kind.startswith('ClassVar'):
            if f.name == 'noise_floor':     # not recorded: unknown
                out[f.name] = math.nan
            elif 'ndarray' in kind:       # a float64[] (Decision's floors)
                out[f.name] = np.zeros(0)
            elif kind.startswith('list'):
                out[f.name] = []
            else:
                out[f.name] = zero[kind] if kind in zero else \
                    store.types['builtin_interfaces/msg/Time'](0, 0)
    return out


def to_header_shape(src, dst, msg_dir):
    """Copy ``src``, recorded with the definitions before std_msgs/Header
    (hri_sync.tools.bag.PRE_HEADER), to ``dst`` with those of
    ``msg_dir``: each such message's stamp field moves into header.stamp
    (frame_id empty, seq 0; a zero stamp where it had none: CaptureCommand,
    ClientResult), every other field is kept.  Returns the number of
    messages converted."""
    from hri_sync.tools.bag import PRE_HEADER
    from hri_sync.tools.session import PRE_HEADER_STAMPS
    old = get_typestore(Stores.ROS1_NOETIC)
    new = get_typestore(Stores.ROS1_NOETIC)
    for kind in PRE_HEADER:
        name = kind.split('/')[1]
        with open('%s/%s.msg' % (msg_dir, name)) as f:
            new.register(get_types_from_msg(f.read(), 'hri_sync/msg/' + name))
    converted = 0
    with Reader(src) as reader, Writer(dst) as writer:
        conns = {}
        for c in reader.connections:
            if c.msgtype not in old.types:
                old.register(get_types_from_msg(c.msgdef.data, c.msgtype))
            kind = c.msgtype.replace('/msg/', '/')
            msgdef, md5 = c.msgdef.data, c.digest
            if PRE_HEADER.get(kind) == c.digest:
                msgdef, md5 = new.generate_msgdef(c.msgtype, ros_version=1)
            conns[c.id] = writer.add_connection(
                c.topic, c.msgtype, msgdef=msgdef, md5sum=md5,
                callerid=c.ext.callerid, latching=c.ext.latching)
        for c, t, raw in reader.messages():
            if PRE_HEADER.get(c.msgtype.replace('/msg/', '/')) == c.digest:
                msg = old.deserialize_ros1(raw, c.msgtype)
                fields = {f.name: getattr(msg, f.name)
                          for f in dataclasses.fields(msg)}
                name = next((n for n in PRE_HEADER_STAMPS if n in fields),
                            None)
                stamp = fields.pop(name) if name else \
                    new.types['builtin_interfaces/msg/Time'](0, 0)
                fields['header'] = new.types['std_msgs/msg/Header'](
                    seq=0, stamp=stamp, frame_id='')
                fields.update(appended(new, c.msgtype, fields))
                raw = new.serialize_ros1(new.types[c.msgtype](**fields),
                                         c.msgtype)
                converted += 1
            writer.write(conns[c.id], t, raw)
    return converted
