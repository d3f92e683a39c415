"""The captured samples' way out: when each may be republished, and its
received bytes with the global stamp written in.

No ROS.  A DPM republishes every sample of a window on ``captured`` with
``header.stamp`` = its global stamp, from a thread of its own, never in a
result's path (``hri_sync.data_process.ros_republisher`` is that thread).
Each sample is serialized as it is captured and goes out ``delay`` s
later, or as soon as its window's result is out: during the window at the
sensor's own pace, so a recorder gets no burst but the window's last
``delay`` s, and memory holds ``delay`` s of samples whatever the window's
length.  The clock is injected (``clock()``: local time, s).
"""
import struct
import threading
from collections import deque
from typing import Any, Callable, Deque, List, Optional, Tuple

from hri_sync.wire.times import fits_ros_time

STAMP = struct.Struct('<II')     # a ROS time: secs, nsecs


def a_time(t: float) -> Optional[float]:
    """``t`` if a ROS time can carry it, else None (no time)."""
    return t if fits_ros_time(t) else None


def with_stamp(raw: bytes, secs: int, nsecs: int) -> bytes:
    """A serialized message whose first field is a std_msgs/Header, with
    the header's stamp (after its uint32 seq) written over."""
    if len(raw) < 4 + STAMP.size:
        raise ValueError('%d bytes cannot hold a header' % len(raw))
    return raw[:4] + STAMP.pack(secs, nsecs) + raw[4 + STAMP.size:]


class Serialized:
    """A message serialized ahead of time: rospy publishes any object with
    the topic type's ``_md5sum`` and a ``serialize(buff)``."""

    __slots__ = ('_md5sum', 'data', 'stamp')

    def __init__(self, md5sum: str, data: bytes, stamp: float) -> None:
        self._md5sum = md5sum
        self.data = data
        self.stamp = stamp

    def serialize(self, buff: Any) -> None:
        buff.write(self.data)


class CaptureQueue:
    """Captured samples between their capture and their republishing.

    ``put`` queues (global stamp, msg, raw bytes or None) as captured;
    ``hold``/``release`` a window [start, end) while its result is not
    out; ``due(serialize)`` serializes what came in (``serialize(stamp,
    msg, raw)`` -> Serialized) and returns, in capture order, what may go
    out now.  Thread-safe.
    """

    def __init__(self, delay: float, clock: Callable[[], float]) -> None:
        self.delay = delay
        self.clock = clock
        self.incoming: Deque[Tuple[float, float, Any, Optional[bytes]]] = \
            deque()
        self.ready: Deque[Tuple[float, Serialized]] = deque()
        self.windows: List[Tuple[float, float]] = []   # held [start, end)
        self.lock = threading.Lock()

    def hold(self, start: float, end: float) -> None:
        """Keep samples stamped in [start, end) until ``release``."""
        with self.lock:
            self.windows.append((start, end))

    def release(self, start: float, end: float) -> None:
        """Let the samples of [start, end) go (a no-op if not held)."""
        with self.lock:
            if (start, end) in self.windows:
                self.windows.remove((start, end))

    def put(self, captured: List[Tuple[float, Any, Optional[bytes]]]) -> None:
        """Queue [(global stamp, msg, serialized msg or None)]."""
        now = self.clock()
        self.incoming.extend((now, t, msg, raw) for t, msg, raw in captured)

    def held(self, t: float) -> bool:
        with self.lock:
            return any(a <= t < b for a, b in self.windows)

    def due(self, serialize: Callable[[float, Any, Optional[bytes]],
                                      Serialized]) -> List[Serialized]:
        """What may go out now, oldest first: held ``delay`` s, or its
        window released."""
        while self.incoming:
            put, t, msg, raw = self.incoming.popleft()
            self.ready.append((put, serialize(t, msg, raw)))
        out = []
        now = self.clock()
        while self.ready:
            put, s = self.ready[0]
            if now - put < self.delay and self.held(s.stamp):
                break
            out.append(self.ready.popleft()[1])
        return out
