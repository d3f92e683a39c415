"""The DPM's republishing thread: captured samples out on ``captured``,
stamped in global time (the queue and its rule:
hri_sync.data_process.republish).
"""
import copy
import io
import threading
import time

import rospy

from hri_sync.ros.outbox import closed_at_shutdown
from hri_sync.ros.stamps import stamp
from hri_sync.data_process.republish import (CaptureQueue, Serialized,
                                             with_stamp)


def serialize(t, msg, raw):
    """The message as received with header.stamp = ``t`` (validated): its
    received bytes with the stamp written over (a header is the first
    field), or a stamped copy serialized."""
    s = stamp(t)
    if raw is not None and msg._has_header:
        data = with_stamp(raw, s.secs, s.nsecs)
    else:
        out = copy.copy(msg)
        if hasattr(msg, 'header'):
            out.header = copy.copy(msg.header)
            out.header.stamp = s
        buff = io.BytesIO()
        out.serialize(buff)
        data = buff.getvalue()
    return Serialized(msg._md5sum, data, t)


class Republisher(CaptureQueue):
    """Publishes on ``pub`` what the queue lets out, from a thread of its
    own.  Bursts go out ``burst`` at a time with a ``pause`` s pause (1000
    a second): rosbag record's subscriber queue holds 100 messages, and a
    recorder starved of CPU for longer than the queue lasts drops the rest
    of a burst."""

    def __init__(self, pub, delay=2.0, burst=20, pause=0.02):
        super().__init__(delay, time.time)
        self.pub = pub
        self.burst = burst
        self.pause = pause
        threading.Thread(target=self.run, daemon=True).start()

    def run(self):
        while not rospy.core.is_shutdown_requested():
            with closed_at_shutdown():
                for n, s in enumerate(self.due(serialize), 1):
                    self.pub.publish(s)
                    if n % self.burst == 0:
                        time.sleep(self.pause)
            time.sleep(self.pause)
