#!/usr/bin/python3
"""An LSL outlet for the LSL tests, on whatever clock it runs under
(launch-prefix faketime): each sample's first channel is its true time
(raw-syscall CLOCK_REALTIME, which libfaketime does not fake, read before
and after its LSL stamp, local_clock(): the midpoint), its second a
counter, its third how long the two reads took (a process preempted
between them stamps its sample late: the checker leaves those out).

Faults, at the middle of round ``~fault_round``'s capture window (read
from /capture_data, global = true time here): ``~fault: vanish`` ends the
process at once (SIGKILL, as a crashed or unplugged source); ``stall``
stops pushing for 3 s, its connection open (a hung source); ``reset``
shifts every later stamp by ``~reset_shift`` s (a device clock that was
reset).  ``~rate`` 0: an irregular marker stream (a marker every
``~marker_period`` s, its text 'TRUTH INDEX READ').  ``~burst`` > 0: the
samples due are pushed together every ``~burst`` s (a device that
delivers in chunks), each stamped when pushed, as LSL does by default:
bunched stamps, nothing lost.
"""
import os
import signal
import threading
import time

from hri_sync.ros.node import init_checker  # noqa: E402
from hri_sync.tools import venv

venv.ensure(['pylsl'], 'lsl_source', __file__)

import pylsl  # noqa: E402
import rospy  # noqa: E402

from hri_sync.msg import CaptureData  # noqa: E402
from hri_sync.clock.truth import true_time  # noqa: E402


class Source:
    def __init__(self):
        self.rate = float(rospy.get_param('~rate', 100.0))
        self.fault = rospy.get_param('~fault', '')
        self.fault_round = int(rospy.get_param('~fault_round', 1))
        self.shift = 0.0
        self.reset_shift = float(rospy.get_param('~reset_shift', -2.0))
        self.fault_at = None
        self.burst = float(rospy.get_param('~burst', 0.0))
        strings = self.rate == 0
        info = pylsl.StreamInfo(
            rospy.get_param('~name', 'hri_test'),
            rospy.get_param('~type', 'Markers' if strings else 'Test'),
            1 if strings else 3, self.rate,
            pylsl.cf_string if strings else pylsl.cf_double64,
            rospy.get_param('~source_id', 'hri_sync_test_source'))
        self.outlet = pylsl.StreamOutlet(info)
        self.period = float(rospy.get_param('~marker_period', 0.5)) \
            if strings else 1.0 / self.rate
        rospy.Subscriber('/capture_data', CaptureData, self.on_capture)

    def on_capture(self, msg):
        start = msg.header.stamp.to_sec() + msg.str_aft
        # A respawned source gets the latched order again: a fault only
        # while it is still ahead.
        if msg.round == self.fault_round and self.fault and \
                start + msg.dur / 2 > true_time():
            self.fault_at = start + msg.dur / 2
            rospy.loginfo('lsl_source: %s at true time %.3f', self.fault,
                          self.fault_at)

    def run(self):
        k = 0
        nxt = time.monotonic()
        while not rospy.is_shutdown():
            if self.burst:
                k = self.push_burst(k)
                continue
            before = true_time()
            stamp = pylsl.local_clock() + self.shift
            after = true_time()
            truth, read = (before + after) / 2, after - before
            if self.fault_at is not None and truth >= self.fault_at:
                self.fault_at = None
                if self.fault == 'vanish':
                    os.kill(os.getpid(), signal.SIGKILL)
                if self.fault == 'stall':
                    rospy.loginfo('lsl_source: stalled for 3 s')
                    time.sleep(3.0)
                    nxt = time.monotonic()
                    continue
                self.shift = self.reset_shift
                rospy.loginfo('lsl_source: stamps shifted by %g s',
                              self.shift)
            if self.rate == 0:
                self.outlet.push_sample(['%.6f %d %.6f' % (truth, k, read)],
                                        stamp)
            else:
                self.outlet.push_sample([truth, float(k), read], stamp)
            k += 1
            nxt += self.period
            time.sleep(max(0.0, nxt - time.monotonic()))


    def push_burst(self, k):
        """Push the samples due since the last burst, each stamped when
        pushed (LSL's default), after ``~burst`` s; returns the count."""
        if not k:
            self.t0 = time.monotonic()
        time.sleep(self.burst)
        due = int((time.monotonic() - self.t0) / self.period)
        for n in range(k, due):
            before = true_time()
            stamp = pylsl.local_clock()
            after = true_time()
            self.outlet.push_sample([(before + after) / 2, float(n),
                                     after - before], stamp)
        return max(k, due)


if __name__ == '__main__':
    init_checker('lsl_source')
    threading.Thread(target=Source().run, daemon=True).start()
    rospy.spin()
