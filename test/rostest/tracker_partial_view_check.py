#!/usr/bin/python3
"""Checks skeleton_tracker's status on a real partial view (issue 18 item 4).

A person 0.7-1.0 m from a real Kinect v1, only the upper body in view, in a
loop: the tracker's /diagnostics says "too close / partial view" (once the
person is in the frame), it never says it is tracking, and any skeleton it
publishes gives the legs (hips, knees, feet) confidence 0.
"""
import time
import unittest

import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray
from hri_sync.msg import ClockState, Skeleton
from hri_sync.ros.node import init_checker

PKG = 'hri_sync'
LEGS = (11, 12, 13, 14)     # knees and feet (hri_sync.dance_off.joints order)


def listen(client):
    """Collects the tracker's statuses and skeletons, and gives it a valid
    global clock (a latched ClockState, offset 0): the two lists filled.
    diagnostic_updater's announcement of a task ('Node starting up', no
    values), which a checker up first sees, is not a status to check."""
    diags, skeletons = [], []
    rospy.Subscriber('/diagnostics', DiagnosticArray,
                     lambda m: diags.extend(
                         s for s in m.status
                         if s.name.startswith(client + '/')
                         and s.values))
    rospy.Subscriber('/%s/skeleton' % client, Skeleton, skeletons.append)
    pub = rospy.Publisher('/%s/clock_state' % client, ClockState,
                          queue_size=1, latch=True)
    pub.publish(ClockState(client_id=client, ok=True,
                           local_ref=time.time(), offset=0.0,
                           drift=0.0, uncertainty=0.001, samples=4))
    return diags, skeletons


class TrackerPartialViewTest(unittest.TestCase):

    def test_partial_view_is_said_and_no_legs_invented(self):
        diags, skeletons = listen(rospy.get_param('~client_id'))
        deadline = time.time() + 40.0
        while time.time() < deadline and not rospy.is_shutdown() and not any(
                'partial view' in s.message for s in list(diags)):
            time.sleep(0.1)
        end = time.time() + rospy.get_param('~duration', 8.0)
        while time.time() < end and not rospy.is_shutdown():
            time.sleep(0.1)
        messages = [s.message for s in diags]
        partial = [m for m in messages if 'too close / partial view' in m]
        self.assertTrue(partial, messages)
        self.assertIn('legs out of view', partial[0])
        self.assertFalse([m for m in messages if m.startswith('tracking')],
                         messages)
        states = [dict((kv.key, kv.value) for kv in s.values).get(
            'tracking_state', '') for s in diags]
        self.assertFalse([s for s in states if s.startswith('tracking')],
                         states)
        for sk in skeletons:
            self.assertEqual([sk.confidence[k] for k in LEGS],
                             [0.0] * len(LEGS), 'legs invented')


if __name__ == '__main__':
    init_checker('tracker_partial_view_check')
    rostest.rosrun(PKG, 'tracker_partial_view', TrackerPartialViewTest)
