#!/usr/bin/python3
"""Checks a round with a real depth clip as one client
(tracker_real_clip_round.test).

The clip's client (~clip_client) runs skeleton_tracker on a real Kinect v1
recording of a person too close and partly in view. After the round:
- the decision came, and the clip's client is not its winner;
- the clip's result has no score above the rule's bar: no usable result
  (no_data), or a value below min_expressiveness and below the noise rule's
  factor times its noise floor;
- every skeleton the tracker published has one user id and legs (hips,
  knees, feet) of confidence 0: no second user, no made-up legs;
- the tracker's /diagnostics said what it sees ("partial view").
"""
import math
import time
import unittest

import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray
from hri_sync.msg import ClientResult, Decision, Skeleton
from hri_sync.ros.node import init_checker

PKG = 'hri_sync'
# hips, knees, feet (hri_sync.dance_off.joints order)
LEGS = (9, 10, 11, 12, 13, 14)


class TrackerRealClipTest(unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        cls.client = rospy.get_param('~clip_client')
        cls.results, cls.decisions = {}, []
        cls.skeletons, cls.messages = [], []
        rospy.Subscriber('/client_result', ClientResult,
                         lambda m: cls.results.__setitem__(m.client_id, m))
        rospy.Subscriber('/decision', Decision, cls.decisions.append)
        rospy.Subscriber('/%s/skeleton' % cls.client, Skeleton,
                         cls.skeletons.append)
        rospy.Subscriber('/diagnostics', DiagnosticArray,
                         lambda m: cls.messages.extend(
                             s.message for s in m.status
                             if s.name.startswith(cls.client + '/')))
        deadline = time.time() + rospy.get_param('~timeout', 90.0)
        while not cls.decisions and time.time() < deadline \
                and not rospy.is_shutdown():
            time.sleep(0.2)
        # results travel on their own connections
        deadline = time.time() + 10.0
        while cls.client not in cls.results and time.time() < deadline \
                and not rospy.is_shutdown():
            time.sleep(0.1)

    def test_clip_never_wins(self):
        self.assertTrue(self.decisions, 'no /decision')
        d = self.decisions[0]
        if d.outcome == Decision.WINNER:
            self.assertNotEqual(d.clients[d.winner - 1], self.client, d.reason)

    def test_clip_scores_nothing_above_the_bar(self):
        r = self.results.get(self.client)
        self.assertIsNotNone(r, 'no result from %s' % self.client)
        if r.status == ClientResult.NO_DATA:
            return
        bar = max(rospy.get_param('/decision_module/min_expressiveness', 1.0),
                  rospy.get_param('/decision_module/noise_factor', 3.0)
                  * (r.noise_floor if math.isfinite(r.noise_floor) else 0.0))
        self.assertLess(r.value, bar, r)

    def test_no_second_user_and_no_legs(self):
        self.assertLessEqual(len({sk.user_id for sk in self.skeletons}), 1)
        for sk in self.skeletons:
            self.assertEqual([sk.confidence[k] for k in LEGS],
                             [0.0] * len(LEGS), 'legs invented')

    def test_partial_view_said(self):
        self.assertTrue([m for m in self.messages if 'partial view' in m],
                        self.messages[-5:])


if __name__ == '__main__':
    init_checker('tracker_real_clip_check')
    rostest.rosrun(PKG, 'tracker_real_clip_round', TrackerRealClipTest)
