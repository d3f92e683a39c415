#!/usr/bin/python3
"""Checks rep155_bridge (issue 21.4) as a ROS4HRI client would see it.

A subscriber built against the hri_msgs/IdsList definition (generated
here from its text, as hri_msgs' own build would) receives
/humans/bodies/tracked; tf lookups of the body's human_description links
in the sensor frame give the skeleton's joints; a skeleton the bridge must
reject (NaN confidence) does not stop it.
"""
import math
import threading
import time
import unittest

import rospy
import rostest
import tf2_ros
from genpy.dynamic import generate_dynamic
from std_msgs.msg import Header

from hri_sync.dance_off.frames import skeleton_point
from hri_sync.dance_off.joints import INDEX
from hri_sync.msg import IdsList, Skeleton
from hri_sync.people.adapters import HUMAN_LINKS
from hri_sync.ros.node import init_checker

# hri_msgs/msg/IdsList.msg (ros4hri/hri_msgs), its fields as released.
HRI_MSGS_IDS_LIST = 'std_msgs/Header header\nstring[] ids\n'
BODY = 'left1'


def hri_msgs_ids_list():
    text = (HRI_MSGS_IDS_LIST + '=' * 80 + '\nMSG: std_msgs/Header\n'
            + Header._full_text)
    return generate_dynamic('hri_msgs/IdsList', text)['hri_msgs/IdsList']


class Rep155(unittest.TestCase):

    @classmethod
    def setUpClass(cls):
        init_checker('rep155_check')
        cls.lock = threading.Lock()
        cls.tracked, cls.skeletons = [], []
        cls.HriIdsList = hri_msgs_ids_list()
        rospy.Subscriber('/humans/bodies/tracked', cls.HriIdsList,
                         cls.on_tracked)
        rospy.Subscriber('/left/skeleton', Skeleton, cls.on_skeleton)
        cls.buffer = tf2_ros.Buffer(rospy.Duration(30))
        cls.listener = tf2_ros.TransformListener(cls.buffer)

    @classmethod
    def on_tracked(cls, msg):
        with cls.lock:
            cls.tracked.append(msg)

    @classmethod
    def on_skeleton(cls, msg):
        if msg.user_id == 1:
            with cls.lock:
                cls.skeletons.append(msg)

    def wait(self, what, timeout=30.0):
        end = time.time() + timeout
        while time.time() < end and not rospy.is_shutdown():
            with self.lock:
                if what():
                    return
            time.sleep(0.1)
        self.fail('timed out')

    def test_ids_list_type_matches_hri_msgs(self):
        self.assertEqual(self.HriIdsList._type, 'hri_msgs/IdsList')
        self.assertEqual(self.HriIdsList._md5sum, IdsList._md5sum)
        self.wait(lambda: any(BODY in m.ids for m in self.tracked))
        with self.lock:
            msg = next(m for m in self.tracked if BODY in m.ids)
        self.assertEqual(msg.ids, [BODY])
        self.assertGreater(msg.header.stamp.to_sec(), 0)

    def test_body_links_give_the_joints(self):
        self.wait(lambda: len(self.skeletons) > 20)
        with self.lock:
            skel = self.skeletons[-10]
        for link, joint in (('head', 'head'), ('torso', 'neck'),
                            ('l_wrist', 'left_hand'),
                            ('r_ankle', 'right_foot'),
                            ('l_elbow', 'left_elbow')):
            tr = self.buffer.lookup_transform(
                'left_sensor', '%s_%s' % (link, BODY), skel.header.stamp,
                rospy.Duration(5.0))
            p = tr.transform.translation
            want = skeleton_point(
                [getattr(skel.positions[INDEX[joint]], a) for a in 'xyz'])
            for got, w in zip((p.x, p.y, p.z), want):
                self.assertAlmostEqual(got, w, places=6, msg=link)
        for link in HUMAN_LINKS:
            self.assertTrue(self.buffer.can_transform(
                'left_sensor', '%s_%s' % (link, BODY), skel.header.stamp),
                link)

    def test_bad_skeleton_is_rejected_not_fatal(self):
        pub = rospy.Publisher('/left/skeleton', Skeleton, queue_size=10)
        time.sleep(1.0)
        bad = Skeleton(client_id='left', user_id=9)
        bad.header.stamp = rospy.Time.now()
        bad.header.frame_id = 'left_sensor'
        bad.device_stamp = bad.header.stamp
        bad.confidence = [math.nan] * 15
        for p in bad.positions:
            p.x, p.y, p.z = 0.0, 1.0, 2.0
        for q in bad.orientations:
            q.w = 1.0
        pub.publish(bad)
        time.sleep(1.0)
        with self.lock:
            n = len(self.tracked)
            seen_bad = any('left9' in m.ids for m in self.tracked)
        self.assertFalse(seen_bad)
        self.wait(lambda: len(self.tracked) > n + 3)


if __name__ == '__main__':
    rostest.rosrun('hri_sync', 'rep155_check', Rep155)
