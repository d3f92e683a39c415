#!/usr/bin/python3
"""Checks skeleton_markers and the site frames
(test/rostest/rviz_markers.test)."""
import math
import threading
import time
import unittest

import numpy as np
import rospy
import rostest
import tf2_ros
from visualization_msgs.msg import Marker, MarkerArray

from hri_sync.msg import Decision
from hri_sync.ros.node import init_checker

TORSO = 2                # joint index; SPHERE_LIST points keep joint order
# The salsa clips' torsos travel up to 1.25 m (cmu_60_01) and 1.49 m
# (cmu_61_01) from the place the layout gives the dancer, and stay 0.57 to
# 1.23 m above the floor; a sensor frame turned the wrong way puts them
# about 5 m off.
PLACE_TOLERANCE = 1.6    # m
TORSO_HEIGHT = (0.4, 1.5)  # m above the floor


def to_world(t, p):
    """Point p of a child frame into its parent through TransformStamped t."""
    q = t.transform.rotation
    x, y, z, w = q.x, q.y, q.z, q.w
    r = np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w),
                   2 * (x * z + y * w)],
                  [2 * (x * y + z * w), 1 - 2 * (x * x + z * z),
                   2 * (y * z - x * w)],
                  [2 * (x * z - y * w), 2 * (y * z + x * w),
                   1 - 2 * (x * x + y * y)]])
    v = t.transform.translation
    return r @ np.array(p) + np.array([v.x, v.y, v.z])


class MarkersCheck(unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        cls.dancers = rospy.get_param('~dancers')
        cls.lock = threading.Lock()
        cls.markers = {}        # (ns, type) -> latest Marker
        cls.after = {}          # the same, after the decision
        cls.decision = None
        cls.tf = tf2_ros.Buffer()
        tf2_ros.TransformListener(cls.tf)
        rospy.Subscriber('/skeleton_markers', MarkerArray, cls.on_markers)
        rospy.Subscriber('/decision', Decision, cls.on_decision)
        deadline = time.monotonic() + rospy.get_param('~timeout')
        # A label may be published just before skeleton_markers hears
        # the decision and reach us just after we did: wait for the
        # winner's label to change (or the timeout).
        while time.monotonic() < deadline and not rospy.is_shutdown():
            with cls.lock:
                if all((c, Marker.TEXT_VIEW_FACING) in cls.after
                       for c in cls.dancers) and cls.winner_labelled():
                    break
            time.sleep(0.1)

    @classmethod
    def winner_labelled(cls):
        d = cls.decision
        if d is None or d.outcome != Decision.WINNER:
            return True
        label = cls.after.get((d.clients[d.winner - 1],
                               Marker.TEXT_VIEW_FACING))
        return label is not None and label.text.endswith(': WINNER')

    @classmethod
    def on_markers(cls, msg):
        with cls.lock:
            for m in msg.markers:
                cls.markers[(m.ns, m.type)] = m
                if cls.decision is not None:
                    cls.after[(m.ns, m.type)] = m

    @classmethod
    def on_decision(cls, msg):
        with cls.lock:
            cls.decision = msg

    def test_joints_and_bones(self):
        for c in self.dancers:
            joints = self.markers.get((c, Marker.SPHERE_LIST))
            bones = self.markers.get((c, Marker.LINE_LIST))
            self.assertIsNotNone(joints, 'no joints of %s' % c)
            self.assertIsNotNone(bones, 'no bones of %s' % c)
            self.assertEqual(joints.header.frame_id, '%s_sensor' % c)
            self.assertEqual(len(joints.points), 15)
            self.assertEqual(len(joints.colors), 15)
            self.assertEqual(len(bones.points), 32)
            self.assertEqual(len(bones.colors), 32)

    def test_winner_highlighted(self):
        d = self.decision
        self.assertIsNotNone(d, 'no decision')
        self.assertEqual(d.outcome, Decision.WINNER, d.reason)
        winner = d.clients[d.winner - 1]
        for c in self.dancers:
            label = self.after.get((c, Marker.TEXT_VIEW_FACING))
            self.assertIsNotNone(label, 'no label of %s after the decision'
                                 % c)
            self.assertEqual(label.text,
                             c + ': WINNER' if c == winner else c)

    def test_frames_place_the_dancers(self):
        for c, (x, y) in self.dancers.items():
            t = self.tf.lookup_transform('world', '%s_sensor' % c,
                                         rospy.Time(0), rospy.Duration(5))
            torso = to_world(t, (lambda p: (p.x, p.y, p.z))(
                self.markers[(c, Marker.SPHERE_LIST)].points[TORSO]))
            self.assertLess(math.hypot(torso[0] - x, torso[1] - y),
                            PLACE_TOLERANCE, '%s torso at %s in world'
                            % (c, torso))
            self.assertTrue(TORSO_HEIGHT[0] < torso[2] < TORSO_HEIGHT[1],
                            '%s torso at %s in world' % (c, torso))
        base = self.tf.lookup_transform('world', 'base_footprint',
                                        rospy.Time(0), rospy.Duration(5))
        self.assertLess(math.hypot(base.transform.translation.x,
                                   base.transform.translation.y), 0.5)


if __name__ == '__main__':
    init_checker('rviz_markers_check')
    rostest.rosrun('hri_sync', 'rviz_markers_check', MarkersCheck)
