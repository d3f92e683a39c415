#!/usr/bin/python3
"""Bad input to skeleton_adapter (issue 20.2/20.6): rejected, counted by
reason on /diagnostics, never a crash; the good frames still go out.

Sends Azure Kinect body markers: good ones, ones of another sensor's frame,
ones with a joint index out of range, with joints missing, with mixed
stamps; and openni tf frames to a second adapter: a good frame, one under
another sensor's frame, one with joints missing.
"""
import time
import unittest

import numpy as np
import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import TransformStamped
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import Marker, MarkerArray

from hri_sync.dance_off.joints import NUM_JOINTS
from hri_sync.msg import Skeleton
from hri_sync.people.adapters import azure_markers, openni_transforms
from hri_sync.ros.node import init_checker


def pose():
    p = np.zeros((NUM_JOINTS, 3))
    p[:, 0] = np.linspace(-0.3, 0.3, NUM_JOINTS)
    p[:, 1] = np.linspace(-0.9, 0.7, NUM_JOINTS)
    p[:, 2] = 2.5
    return p


def marker_array(t, frame='depth_camera_link', body=0, drop=(), bad=None,
                 late=None):
    out = MarkerArray()
    for mid, xyz in azure_markers(body, pose()):
        if mid % 100 in drop:
            continue
        m = Marker()
        m.header.stamp = rospy.Time.from_sec(t + (0.01 if mid == late
                                                  else 0.0))
        m.header.frame_id = frame
        m.id = bad if mid == body * 100 + 5 and bad is not None else mid
        m.pose.position.x, m.pose.position.y, m.pose.position.z = xyz
        m.pose.orientation.w = 1.0
        out.markers.append(m)
    return out


def tf_frames(t, parent='openni_depth_frame', user=1, count=NUM_JOINTS):
    """One frame's transforms in one message: they arrive together, so a
    loaded machine cannot split a frame in two (the adapter's grouping of
    transforms sent one by one is adapter_openni_tf's test)."""
    transforms = []
    for child, xyz in openni_transforms(user, pose())[:count]:
        tr = TransformStamped()
        tr.header.stamp = rospy.Time.from_sec(t)
        tr.header.frame_id = parent
        tr.child_frame_id = child
        (tr.transform.translation.x, tr.transform.translation.y,
         tr.transform.translation.z) = xyz
        tr.transform.rotation.w = 1.0
        transforms.append(tr)
    return [TFMessage(transforms=transforms)]


class AdapterBadInput(unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        init_checker('adapter_bad_input_check')
        cls.out = {'azure': [], 'openni': []}
        cls.diag = {}
        rospy.Subscriber('/azure/skeleton', Skeleton,
                         lambda m: cls.out['azure'].append(m))
        rospy.Subscriber('/openni/skeleton', Skeleton,
                         lambda m: cls.out['openni'].append(m))
        rospy.Subscriber('/diagnostics', DiagnosticArray, cls.on_diag)
        markers = rospy.Publisher('/body_tracking_data', MarkerArray,
                                  queue_size=100)
        tf = rospy.Publisher('/tf', TFMessage, queue_size=1000)
        time.sleep(2.0)
        t = time.time()
        markers.publish(marker_array(t))                        # good
        markers.publish(marker_array(t + 0.1, frame='rgb_camera_link'))
        markers.publish(marker_array(t + 0.2, bad=40))          # bad id
        markers.publish(marker_array(t + 0.3, drop=(26,)))      # no HEAD
        markers.publish(marker_array(t + 0.4, late=3))          # mixed
        markers.publish(marker_array(t + 0.5, body=1))          # good
        for k, msgs in enumerate((
                tf_frames(t),                                   # good
                tf_frames(t + 0.1, parent='camera_depth_frame'),
                tf_frames(t + 0.2, count=10),                   # missing
                tf_frames(t + 0.3, user=2))):                   # good
            for m in msgs:
                tf.publish(m)
            time.sleep(0.1)
        time.sleep(3.0)

    @classmethod
    def on_diag(cls, msg):
        for s in msg.status:
            if s.name.endswith('input'):
                cls.diag[s.name] = {kv.key: kv.value for kv in s.values}

    def counts(self, node):
        for name, values in self.diag.items():
            if node in name:
                return values
        self.fail('no input status of %s on /diagnostics: %s'
                  % (node, sorted(self.diag)))

    def test_azure(self):
        self.assertEqual([m.user_id for m in self.out['azure']], [1, 2])
        c = self.counts('azure/adapter')
        text = ' '.join('%s=%s' % kv for kv in sorted(c.items()))
        for reason in ('wrong_frame', 'bad_id', 'missing_joints',
                       'mixed_stamps'):
            self.assertTrue(any(reason in k and v == '1'
                                for k, v in c.items()), (reason, text))

    def test_openni(self):
        self.assertEqual([m.user_id for m in self.out['openni']], [1, 2])
        c = self.counts('openni/adapter')
        text = ' '.join('%s=%s' % kv for kv in sorted(c.items()))
        for reason in ('wrong_frame', 'missing_joints'):
            self.assertTrue(any(reason in k and v == '1'
                                for k, v in c.items()), (reason, text))


if __name__ == '__main__':
    rostest.rosrun('hri_sync', 'adapter_bad_input_check', AdapterBadInput)
