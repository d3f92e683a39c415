"""Reading session recordings (rosbag 1) without ROS.

Uses the pure-Python ``rosbags`` library (imported on use). What goes
wrong gets a ``BagError`` that says what and what to do: a bag whose
recorder was killed (``X.bag.active``, no index; ``reindex`` salvages it),
an empty bag, messages recorded with another version of hri_sync's
message definitions (their md5sums differ from this package's ``msg/``).
Messages are decoded with the definitions recorded in the bag itself, so
a field a bag lacks is simply absent from its messages.

One older version is read as a matter of course: the definitions just
before the timestamped messages got a ``std_msgs/Header`` (``PRE_HEADER``),
whose global stamp is in its own field (``stamp``, ``cr_t`` of a
CaptureData, ``actual`` of an ActionStart); ``session.stamp_of`` reads
both shapes.
"""
import glob
import os
import re
import struct
from dataclasses import dataclass, field

PKG = 'hri_sync'
# A part of a recording that rosbag record --split wrote: PREFIX_N.bag.
SPLIT_PART = re.compile(r'^(.*)_(\d+)\.bag$')
MAGIC = b'#ROSBAG V2.0\n'
OP_MSGDATA, OP_BAGHEADER, OP_IDXDATA, OP_CHUNK, OP_CHUNKINFO, OP_CONN = \
    2, 3, 4, 5, 6, 7


# md5sums of the definitions before std_msgs/Header: every
# other field as now.
PRE_HEADER = {
    'hri_sync/ActionStart': 'fe01d6e1508656b37f44bd4744df470b',
    'hri_sync/Beat': 'cccc2c950ebda498796d9c8e2b00cbf0',
    'hri_sync/CaptureCommand': 'ee29ab455ee0ce7e1aa3e082c61473c9',
    'hri_sync/CaptureData': '883c9c56a6d7b6333abbe6f2fb39ed6a',
    'hri_sync/ClientResult': 'acac2b405079bc53753177a99ef9d8de',
    'hri_sync/Decision': '1eba2c819c38cb6c6e1c0ae637e9e952',
    'hri_sync/RoundStatus': 'c68b48bc6bd4f04bb0e7962af502264e',
    'hri_sync/SyncAck': '6aa0903f0f0c64e25807457eb45a269d',
    'hri_sync/SyncTime': 'e035faab1d0985f73ad882f146234ff7',
}

# md5sums of definitions today's only extend with fields at the end
# (ActionStart's kind, event, status, ...; ClientResult's noise_floor, then
# noise_source; Decision's noise_floors; Skeleton's frame_index,
# frames_skipped and sources), oldest first: read as they are, without the
# appended fields.
APPENDED = {
    'hri_sync/ActionStart': ('afa9bd87c199ede36d50d1488f2c8ff8',),
    'hri_sync/ClientResult': ('4be20d7e3c87c82059393adb83f3435f',
                              '8ed9e139336825069cfc0365383a0d62'),
    'hri_sync/Decision': ('f79083d8878f6b9e5010c20090402872',),
    'hri_sync/Skeleton': ('8c168feb7dcf11c4819ee7ddd6080a4b',),
}


class BagError(Exception):
    """A recording that cannot be read as it is, and why."""


def _stamp(t):
    """A rosbags Time (sec, nanosec) in seconds."""
    return t.sec + t.nanosec * 1e-9


@dataclass
class Recorded:
    """One recorded message: bag (receipt) time in s, topic, message."""

    t: float
    topic: str
    msg: object


@dataclass
class BagContents:
    """Every message of a bag, in receipt order, by topic."""

    path: str
    start: float = 0.0                      # bag time of the first message
    end: float = 0.0
    topics: dict = field(default_factory=dict)     # topic -> type
    messages: dict = field(default_factory=dict)   # topic -> [Recorded]
    old_types: dict = field(default_factory=dict)  # type -> (bag, ours)
    pre_header: list = field(default_factory=list)  # types, PRE_HEADER

    def of_type(self, msgtype, suffix=''):
        """[Recorded] of every topic of ``msgtype`` (``pkg/Name``) whose
        name ends with ``suffix``, in bag time order."""
        out = [r for topic, kind in self.topics.items()
               if kind == msgtype and topic.endswith(suffix)
               for r in self.messages.get(topic, [])]
        out.sort(key=lambda r: r.t)
        return out


def msg_dir():
    """This package's msg/ folder, or None if it cannot be found."""
    here = os.path.dirname(os.path.abspath(__file__))
    candidates = [os.environ.get('HRI_SYNC_MSG_DIR', ''),
                  os.path.join(here, '..', '..', '..', 'msg'),
                  os.path.join(here, '..', '..', '..', '..', '..', 'share',
                               PKG, 'msg')]
    for c in candidates:
        if c and glob.glob(os.path.join(c, '*.msg')):
            return os.path.normpath(c)
    try:
        import rospkg
        path = os.path.join(rospkg.RosPack().get_path(PKG), 'msg')
        return path if os.path.isdir(path) else None
    except Exception:   # no ROS: the source tree was the last hope
        return None


def current_md5sums(folder=None):
    """{'hri_sync/Name': md5} of this package's message definitions."""
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore
    folder = folder or msg_dir()
    if folder is None:
        return {}
    store = get_typestore(Stores.ROS1_NOETIC)
    types = {}
    for path in sorted(glob.glob(os.path.join(folder, '*.msg'))):
        name = os.path.splitext(os.path.basename(path))[0]
        with open(path) as f:
            types.update(get_types_from_msg(f.read(),
                                            '%s/msg/%s' % (PKG, name)))
    store.register(types)
    return {t.replace('/msg/', '/'): store.generate_msgdef(
        t, ros_version=1)[1] for t in types}


def _index_pos(path):
    """The bag header's index position (0: never closed), or None if
    ``path`` does not start like a rosbag 2.0 file."""
    with open(path, 'rb') as f:
        head = f.read(4096 + 64)
    if not head.startswith(MAGIC):
        return None
    header, _ = _record(head, len(MAGIC))
    if header is None or 'index_pos' not in header:
        return None
    return struct.unpack('<Q', header['index_pos'])[0]


def unclosed(path):
    """The file of ``path`` that a killed recorder left unclosed (``path``
    itself or ``path.active``), or None."""
    if not os.path.exists(path):
        active = path + '.active'
        return active if os.path.isfile(active) else None
    if os.path.isfile(path) and (path.endswith('.active') or
                                 (os.path.getsize(path) > 0 and
                                  _index_pos(path) == 0)):
        return path
    return None


def reindexed_path(active):
    """Where ``--reindex`` writes the bag salvaged from ``active``."""
    if active.endswith('.bag.active'):
        return active[:-len('.active')]
    base = active[:-len('.bag')] if active.endswith('.bag') else active
    return base + '.reindexed.bag'


def unclosed_message(active):
    """What to say about a bag whose recorder never closed it."""
    final = reindexed_path(active)
    return ('%s was not closed: its recorder was killed (or is still '
            'running), so the bag has no index. Reindex it with '
            '"rosbag reindex %s" (ROS; then rename it to %s), or let this '
            'tool do it without ROS: --reindex (writes %s)'
            % (active, active, final, final))


def _check_readable(path):
    active = unclosed(path)
    if active:
        raise BagError(unclosed_message(active))
    if not os.path.exists(path):
        raise BagError('%s: no such file' % path)
    if os.path.isdir(path):
        raise BagError('%s is a folder, not a rosbag' % path)
    if os.path.getsize(path) == 0:
        raise BagError('%s is an empty file (0 bytes): nothing was recorded'
                       % path)
    if _index_pos(path) is None:
        raise BagError('%s is not a rosbag 2.0 file' % path)


def _absolute(topic):
    return '/' + topic.lstrip('/')


def read_bag(path, allow_old=False, md5sums=None):
    """Every message of ``path`` as a BagContents.

    Raises BagError for an unreadable, unclosed or empty bag, and for
    hri_sync messages recorded with other definitions than this package's
    (unless ``allow_old``: then they are decoded with the bag's own
    definitions and listed in ``old_types``); the ``PRE_HEADER`` ones are
    read and listed in ``pre_header``. ``md5sums``: this package's
    ({type: md5}, default ``current_md5sums()``).  A topic recorded by
    its relative name (``rosbag record`` in a system's namespace, as the
    site files run it: ``decision``) is read as ``/decision``.
    """
    from rosbags.rosbag1 import Reader, ReaderError
    from rosbags.typesys import Stores, get_types_from_msg, get_typestore
    _check_readable(path)
    ours = current_md5sums() if md5sums is None else md5sums
    store = get_typestore(Stores.ROS1_NOETIC)
    contents = BagContents(path)
    try:
        with Reader(path) as reader:
            if not reader.connections or reader.message_count == 0:
                raise BagError('%s holds no messages: nothing was recorded'
                               % path)
            registered = {}
            for conn in reader.connections:
                kind = conn.msgtype.replace('/msg/', '/')
                contents.topics[_absolute(conn.topic)] = kind
                want = ours.get(kind)
                if want is None or conn.digest == want or \
                        conn.digest in APPENDED.get(kind, ()):
                    pass
                elif PRE_HEADER.get(kind) == conn.digest:
                    if kind not in contents.pre_header:
                        contents.pre_header.append(kind)
                else:
                    contents.old_types[kind] = (conn.digest, want)
                if registered.get(conn.msgtype, conn.digest) != conn.digest:
                    raise BagError(
                        '%s holds two versions of %s (md5 %s and %s)'
                        % (path, kind, registered[conn.msgtype],
                           conn.digest))
                if conn.msgtype not in registered:
                    registered[conn.msgtype] = conn.digest
                    store.register(get_types_from_msg(conn.msgdef.data,
                                                      conn.msgtype))
            if contents.old_types and not allow_old:
                raise BagError('%s was recorded with other hri_sync message '
                               'definitions than this package\'s: %s. '
                               'Read it with the version of hri_sync that '
                               'recorded it, or pass --allow-old-messages '
                               'to read it with the definitions it holds '
                               '(fields it lacks are shown as n/a)' % (
                                   path, '; '.join(
                                       '%s has md5 %s in the bag, %s here'
                                       % (k, v[0], v[1]) for k, v in
                                       sorted(contents.old_types.items()))))
            for conn, t_ns, raw in reader.messages():
                msg = store.deserialize_ros1(raw, conn.msgtype)
                topic = _absolute(conn.topic)
                contents.messages.setdefault(topic, []).append(
                    Recorded(t_ns * 1e-9, topic, msg))
            # A topic whose connection holds no message was not recorded.
            contents.topics = {t: k for t, k in contents.topics.items()
                               if t in contents.messages}
            contents.start = reader.start_time * 1e-9
            contents.end = reader.end_time * 1e-9
    except ReaderError as e:
        raise BagError('%s cannot be read: %s' % (path, e))
    return contents


# --- reindexing a bag whose recorder was killed -----------------------------

def _record(buf, pos):
    """(header fields, data (start, length)) of the record at ``pos`` of
    ``buf``, or (None, None) if it is truncated or malformed."""
    if pos + 4 > len(buf):
        return None, None
    hlen = struct.unpack_from('<I', buf, pos)[0]
    if hlen > len(buf) - pos - 8:
        return None, None
    fields, p, end = {}, pos + 4, pos + 4 + hlen
    while p < end:
        flen = struct.unpack_from('<I', buf, p)[0]
        if p + 4 + flen > end:
            return None, None
        name, sep, value = bytes(buf[p + 4:p + 4 + flen]).partition(b'=')
        if not sep:
            return None, None
        fields[name.decode('latin-1')] = value
        p += 4 + flen
    dlen = struct.unpack_from('<I', buf, end)[0]
    if end + 4 + dlen > len(buf):
        return fields, (end + 4, -1)
    return fields, (end + 4, dlen)


def _op(fields):
    return fields.get('op', b'\xff')[0]


def _fields(data):
    """Header-style fields packed in a connection record's data."""
    fields, p = {}, 0
    while p + 4 <= len(data):
        flen = struct.unpack_from('<I', data, p)[0]
        name, _, value = bytes(data[p + 4:p + 4 + flen]).partition(b'=')
        fields[name.decode('latin-1')] = value.decode('utf-8', 'replace')
        p += 4 + flen
    return fields


def _chunk_records(buf):
    """Connection and message records of a chunk's data, until the end or
    the first truncated record: (conns {id: fields}, [(conn, t_ns, data)])."""
    conns, msgs, pos = {}, [], 0
    while pos < len(buf):
        fields, data = _record(buf, pos)
        if fields is None or data[1] < 0:
            break
        start, length = data
        op = _op(fields)
        if op == OP_CONN:
            cid = struct.unpack('<I', fields['conn'])[0]
            info = _fields(buf[start:start + length])
            info.setdefault('topic', fields.get('topic', b'').decode())
            conns[cid] = info
        elif op == OP_MSGDATA:
            cid = struct.unpack('<I', fields['conn'])[0]
            sec, nsec = struct.unpack('<II', fields['time'])
            msgs.append((cid, sec * 10 ** 9 + nsec,
                         bytes(buf[start:start + length])))
        pos = start + length
    return conns, msgs


@dataclass
class Salvage:
    """What reindexing found."""

    messages: int = 0
    chunks: int = 0
    lost_chunks: int = 0        # compressed chunks cut off mid-write
    topics: dict = field(default_factory=dict)  # topic -> messages


def reindex(src, dst):
    """Rebuild an unclosed bag ``src`` (``.bag.active``) into ``dst``.

    Reads every complete chunk and the records of the chunk that was being
    written when the recorder died (uncompressed chunks are written record
    by record; a compressed chunk cut off mid-write is lost and counted),
    and writes them to a new, indexed bag. Returns a Salvage. Needs no ROS.
    """
    from rosbags.rosbag1 import Writer
    from rosbags.rosbag1.reader import decompressors
    with open(src, 'rb') as f:
        buf = f.read()
    if not buf.startswith(MAGIC):
        raise BagError('%s is not a rosbag 2.0 file' % src)
    header, data = _record(buf, len(MAGIC))
    if header is None or _op(header) != OP_BAGHEADER or data[1] < 0:
        raise BagError('%s: no readable bag header' % src)
    pos = data[0] + data[1]
    salvage, conns, msgs = Salvage(), {}, []
    while pos < len(buf):
        fields, data = _record(buf, pos)
        if fields is None:
            break
        start, length = data
        op = _op(fields)
        if op == OP_CHUNK:
            compression = fields.get('compression', b'none').decode()
            if compression == 'none' and (length <= 0 or
                                          struct.unpack(
                                              '<I', fields['size'])[0] == 0):
                # The chunk being written: its records run to the end.
                c, m = _chunk_records(memoryview(buf)[start:])
                conns.update(c)
                msgs.extend(m)
                salvage.chunks += 1
                break
            if length < 0:
                salvage.lost_chunks += 1
                break
            try:
                raw = decompressors[compression](buf[start:start + length])
            except Exception:   # a compressed chunk cut off mid-write
                salvage.lost_chunks += 1
                break
            c, m = _chunk_records(memoryview(raw))
            conns.update(c)
            msgs.extend(m)
            salvage.chunks += 1
        elif op == OP_CONN and length >= 0:
            cid = struct.unpack('<I', fields['conn'])[0]
            conns.setdefault(cid, _fields(buf[start:start + length]))
        if length < 0:
            break
        pos = start + length
    msgs = [m for m in msgs if m[0] in conns]
    if not msgs:
        raise BagError('%s: no message could be salvaged' % src)
    msgs.sort(key=lambda m: m[1])
    with Writer(dst) as writer:
        out = {}
        for cid, info in sorted(conns.items()):
            kind = info['type']
            if '/msg/' not in kind:
                kind = kind.replace('/', '/msg/', 1)
            latching = info.get('latching')
            out[cid] = writer.add_connection(
                info['topic'], kind, msgdef=info['message_definition'],
                md5sum=info['md5sum'], callerid=info.get('callerid'),
                latching=int(latching) if latching else None)
        for cid, t_ns, raw in msgs:
            writer.write(out[cid], t_ns, raw)
            salvage.messages += 1
            topic = conns[cid]['topic']
            salvage.topics[topic] = salvage.topics.get(topic, 0) + 1
    return salvage


def open_bags(paths, allow_old=False, do_reindex=False, say=print):
    """read_bag for each path; with ``do_reindex``, an unclosed bag is
    reindexed first (next to it, see ``reindexed_path``) and that read."""
    out = []
    for path in paths:
        active = unclosed(path)
        if active and do_reindex:
            dst = reindexed_path(active)
            if os.path.exists(dst):
                raise BagError('%s exists already: not overwriting it with '
                               'the reindexed %s' % (dst, active))
            s = reindex(active, dst)
            say('%s: reindexed into %s: %d messages in %d chunks%s'
                % (active, dst, s.messages, s.chunks,
                   '; %d compressed chunk(s) cut off mid-write were lost'
                   % s.lost_chunks if s.lost_chunks else ''))
            path = dst
        out.append(read_bag(path, allow_old))
    return out


def split_groups(paths):
    """``paths`` grouped by recording: the parts that ``rosbag record
    --split`` wrote (PREFIX_0.bag, PREFIX_1.bag, ...) together in part
    order, every other bag alone; groups in the order of their first
    path."""
    groups, where = [], {}
    for path in paths:
        m = SPLIT_PART.match(path)
        if m is None:
            groups.append([path])
        elif m.group(1) in where:
            groups[where[m.group(1)]].append(path)
        else:
            where[m.group(1)] = len(groups)
            groups.append([path])
    return [sorted(g, key=lambda p: int(SPLIT_PART.match(p).group(2)))
            if len(g) > 1 else g for g in groups]


def group_label(paths):
    """How a group of split_groups is named in messages."""
    if len(paths) == 1:
        return paths[0]
    return '%s .. %s (%d split parts)' % (paths[0],
                                          os.path.basename(paths[-1]),
                                          len(paths))


def merge_contents(parts):
    """One BagContents of the parts of a split recording, in order: one
    session, where each part alone lacks what came before it (a latched
    message such as /dance_off/config is in the first part only) and
    cuts the rounds that cross its ends."""
    if len(parts) == 1:
        return parts[0]
    out = BagContents(parts[0].path, start=min(p.start for p in parts),
                      end=max(p.end for p in parts))
    for part in parts:
        out.topics.update(part.topics)
        for topic, recs in part.messages.items():
            out.messages.setdefault(topic, []).extend(recs)
        out.old_types.update(part.old_types)
        out.pre_header.extend(t for t in part.pre_header
                              if t not in out.pre_header)
    for recs in out.messages.values():
        recs.sort(key=lambda r: r.t)
    return out


def open_session(paths, allow_old=False, do_reindex=False, say=print):
    """open_bags of one group of split_groups, merged into one
    BagContents."""
    return merge_contents(open_bags(paths, allow_old, do_reindex, say))
