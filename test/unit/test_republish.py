"""hri_sync.data_process.republish: when captured samples go out, and their
bytes with the global stamp written in."""
import io
import struct

import pytest

from hri_sync.data_process.republish import (CaptureQueue, Serialized, a_time,
                                             with_stamp)


class Clock:
    def __init__(self):
        self.t = 100.0

    def __call__(self):
        return self.t


def serialize(t, msg, raw):
    return Serialized('md5', b'%s' % msg.encode(), t)


def test_a_sample_waits_delay_or_its_windows_release():
    clock = Clock()
    q = CaptureQueue(2.0, clock)
    q.hold(10.0, 20.0)
    q.put([(10.5, 'a', None), (25.0, 'outside', None)])
    assert [s.stamp for s in q.due(serialize)] == []
    # Not held: 'outside' may go, but not ahead of 'a' (capture order).
    clock.t += 1.0
    q.put([(11.0, 'b', None)])
    assert q.due(serialize) == []
    clock.t += 1.0                  # 'a' has waited its 2 s
    assert [s.data for s in q.due(serialize)] == [b'a', b'outside']
    q.release(10.0, 20.0)           # the result is out: 'b' goes at once
    assert [s.data for s in q.due(serialize)] == [b'b']
    q.release(10.0, 20.0)           # a second release is a no-op


def test_with_stamp_writes_the_header_stamp_after_the_seq():
    seq, secs, nsecs = 7, 1234, 5678
    raw = struct.pack('<III', seq, 1, 2) + b'\x03\x00\x00\x00abc' + b'rest'
    out = with_stamp(raw, secs, nsecs)
    assert struct.unpack('<III', out[:12]) == (seq, secs, nsecs)
    assert out[12:] == raw[12:] and len(out) == len(raw)
    with pytest.raises(ValueError, match='cannot hold a header'):
        with_stamp(b'\x00' * 8, 1, 2)


def test_serialized_writes_its_bytes():
    buff = io.BytesIO()
    Serialized('m', b'xyz', 1.0).serialize(buff)
    assert buff.getvalue() == b'xyz'


@pytest.mark.parametrize('t, ok', [(1.5, True), (0.0, False),
                                   (float('nan'), False), (2.0 ** 32, False)])
def test_a_time_is_none_where_a_ros_time_cannot_carry_it(t, ok):
    assert (a_time(t) is not None) == ok
