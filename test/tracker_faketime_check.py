#!/usr/bin/python3
"""Checks a dance-off round whose tracker client runs under libfaketime.

The checks of tracker_dance_off_check.py (the winner, both results ok, the
tracker client's ~30 Hz frames), and that the tracker's skeletons are
stamped in global time although its client's local clock is faked: this
node runs on the true clock, which the loopback time server serves, so
each skeleton's true arrival time minus its header.stamp is its delay
after capture: never below -~max_early (the client's clock uncertainty)
and in the median below ~max_latency (measured: 1-12 ms, median 3 ms). A
tracker outside the faketime (reading the true clock) that converts it with
the faked clock's ClockState is off by the fake offset (measured: 1.505 s
with a +1.5 s clock).
"""
import time

import numpy as np
import rospy
import rostest
from hri_sync.msg import Skeleton
from tracker_dance_off_check import TrackerDanceOffTest

PKG = 'hri_sync'


class TrackerFaketimeTest(TrackerDanceOffTest):

    @classmethod
    def setUpClass(cls):
        cls.latencies = []
        rospy.Subscriber(
            '/%s/skeleton' % rospy.get_param('~tracker_client'), Skeleton,
            lambda m: cls.latencies.append(
                time.time() - m.header.stamp.to_sec()))
        super().setUpClass()

    def test_tracker_stamps_global(self):
        latency = np.array(self.latencies)
        self.assertGreaterEqual(len(latency), 30,
                                'only %d skeletons' % len(latency))
        rospy.loginfo('tracker latency (true arrival - stamp) over %d '
                      'skeletons: min %.4f, median %.4f, max %.4f s',
                      len(latency), latency.min(), np.median(latency),
                      latency.max())
        self.assertGreater(latency.min(), -rospy.get_param('~max_early'),
                           'stamps after their arrival: %.4f s'
                           % latency.min())
        self.assertLess(np.median(latency), rospy.get_param('~max_latency'),
                        'stamps not in global time: median latency %.4f s'
                        % np.median(latency))


if __name__ == '__main__':
    rospy.init_node('tracker_faketime_check')
    rostest.rosrun(PKG, 'tracker_faketime', TrackerFaketimeTest)
