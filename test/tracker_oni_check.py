#!/usr/bin/python3
"""Checks the skeleton_tracker node on an .oni recording (issue 5).

Plays the CPM's part: publishes a latched /<client_id>/clock_state with a
large offset and a drift, collects /<client_id>/skeleton and checks that
- skeletons arrive, with device_stamp filled and a confidence per joint;
- header.stamp is global time: global(local arrival) minus the stamp is a
  small, non-negative latency, and stamp - device_stamp is one constant (the
  device clock was mapped by a fit, not by each frame's arrival);
- the joints are near the recorded motion's true joints (the recording's
  device clock starts at the motion's t = 0): mean error and hands p95
  within the issue's targets (0.10 m, 0.25 m) on this short fixture (measured
  0.033 m and 0.12 m). On whole clips the hands p95 is above the target:
  bench/tracker_accuracy.py measures it and docs/tracker.md reports it.
"""
import os
import time
import unittest

import numpy as np
import rospy
import rostest
from hri_sync.msg import ClockState, Skeleton

PKG = 'hri_sync'
HANDS = (7, 8)


class TrackerOniTest(unittest.TestCase):

    def setUp(self):
        self.client = rospy.get_param('~client_id', 'trk')
        self.offset = rospy.get_param('~clock_offset', 1000.0)
        self.drift = rospy.get_param('~clock_drift', 5e-5)
        self.local_ref = time.time()
        self.msgs = []
        self.pub = rospy.Publisher('/%s/clock_state' % self.client,
                                   ClockState, queue_size=1, latch=True)
        self.pub.publish(ClockState(client_id=self.client, ok=True,
                                    local_ref=self.local_ref,
                                    offset=self.offset, drift=self.drift,
                                    uncertainty=0.001, samples=5))
        rospy.Subscriber(
            '/%s/skeleton' %
            self.client,
            Skeleton,
            self.on_skeleton)

    def to_global(self, local):
        return local + self.offset + self.drift * (local - self.local_ref)

    def on_skeleton(self, msg):
        self.msgs.append((self.to_global(time.time()), msg))

    def test_oni_through_tracker(self):
        duration = rospy.get_param('~duration', 8.0)
        deadline = time.time() + duration
        while time.time() < deadline and not rospy.is_shutdown():
            time.sleep(0.1)
        msgs = self.msgs
        self.assertGreaterEqual(
            len(msgs),
            30,
            'only %d skeletons from the recording' %
            len(msgs))

        arrival = np.array([a for a, _ in msgs])
        stamp = np.array([m.header.stamp.to_sec() for _, m in msgs])
        device = np.array([m.device_stamp.to_sec() for _, m in msgs])
        latency = arrival - stamp
        self.assertTrue(
            np.all(
                latency > -
                0.005),
            'stamps in the future: %s' %
            latency.min())
        self.assertLess(np.median(latency), 0.15,
                        'stamps are not global time (latency %.3f s)'
                        % np.median(latency))
        gap = stamp - device * (1 + self.drift)
        self.assertLess(
            np.ptp(gap),
            0.010,
            'stamp - device_stamp varies by %.4f s' %
            np.ptp(gap))
        for _, m in msgs:
            self.assertEqual(m.client_id, self.client)
            self.assertTrue(all(0.0 <= c <= 1.0 for c in m.confidence))

        motion = rospy.get_param('~motion', 'cmu_60_01_salsa')
        track = np.loadtxt(os.path.join(os.path.dirname(__file__), '..',
                                        'data', 'motion', motion + '.track'))
        times, truth = track[:, 0], track[:, 1:].reshape(len(track), 15, 3)
        est = np.array([[[p.x, p.y, p.z] for p in m.positions]
                       for _, m in msgs])

        def errors(lag):
            t = device + lag
            true = np.stack([np.stack([np.interp(t, times, truth[:, j, k])
                                       for k in range(3)], -1)
                             for j in range(15)], 1)
            return np.linalg.norm(est - true, axis=2)
        # The recorder may start a frame late: allow a lag of a few frames.
        err = min((errors(lag)
                  for lag in np.arange(-0.1, 0.1001, 1.0 / 120)), key=np.mean)
        mean, hands_p95 = err.mean(), np.percentile(err[:, HANDS], 95)
        rospy.loginfo('tracker_oni: %d skeletons, mean error %.3f m, '
                      'hands p95 %.3f m, median latency %.1f ms',
                      len(msgs), mean, hands_p95,
                      1e3 * np.median(latency))
        self.assertLessEqual(
            mean,
            0.10,
            'mean joint error %.3f m > 0.10 m' %
            mean)
        self.assertLessEqual(hands_p95, 0.25,
                             'hands p95 error %.3f m > 0.25 m' % hands_p95)


if __name__ == '__main__':
    rospy.init_node('tracker_oni_check')
    rostest.rosrun(PKG, 'tracker_oni', TrackerOniTest)
