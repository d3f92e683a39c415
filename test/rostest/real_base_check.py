#!/usr/bin/python3
"""Stands in for a real Turtlebot 2's base (issue 19 item 3) and checks
that DJ Rob drives it through the remapping of dj_rob.launch robot:=real.

Runs as /mobile_base_nodelet_manager, the node kobuki_node's launch files
load the base into: publishes /odom (integrating the commands it gets)
and receives /mobile_base/commands/velocity, led1, led2 and sound, the
LEDs and the sound with message classes generated here from kobuki_msgs'
definitions (as kobuki_msgs' own build would: type kobuki_msgs/Led and
kobuki_msgs/Sound, their md5sums), while the system runs in /lab1.
Checks: the classes have kobuki_msgs' names and md5sums; the dance's and
the gesture's commands arrive on the root topics (none on /lab1's), with
an explicit zero at the end; the winner gesture's LEDs and sound arrive
as kobuki_msgs messages, sent as hri_sync/Led and hri_sync/Sound (the
publisher's type in the connection header); DJ Rob took the odometry
(its start pose came from /odom; no dead reckoning, no rejection).
"""
import math
import threading
import time
import unittest

import rospy
import rostest
from genpy.dynamic import generate_dynamic
from geometry_msgs.msg import Quaternion, Twist
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Log

from constant_samples import publish_constant_samples
from hri_sync.msg import Decision, Led, Sound
from hri_sync.ros.outbox import closed_at_shutdown
from hri_sync.ros.node import init_checker

# kobuki_msgs/msg/Led.msg and Sound.msg (yujinrobot/kobuki_msgs): their
# constants and field, as released (comments left out: the md5sum
# ignores them), and the md5sums kobuki_msgs' generated code carries.
KOBUKI_LED = ('uint8 BLACK   = 0\nuint8 GREEN   = 1\nuint8 ORANGE  = 2\n'
              'uint8 RED     = 3\nuint8 value\n')
KOBUKI_SOUND = ('uint8 ON            = 0\nuint8 OFF           = 1\n'
                'uint8 RECHARGE      = 2\nuint8 BUTTON        = 3\n'
                'uint8 ERROR         = 4\nuint8 CLEANINGSTART = 5\n'
                'uint8 CLEANINGEND   = 6\nuint8 value\n')
KOBUKI_MD5 = {'kobuki_msgs/Led': '4391183b0cf05f8f25d04220401b9f43',
              'kobuki_msgs/Sound': 'dfeab0daae67749c426c1db741a4f420'}
KobukiLed = generate_dynamic('kobuki_msgs/Led', KOBUKI_LED)[
    'kobuki_msgs/Led']
KobukiSound = generate_dynamic('kobuki_msgs/Sound', KOBUKI_SOUND)[
    'kobuki_msgs/Sound']


class RealBase(unittest.TestCase):
    """One round of DJ Rob driving the stand-in base."""

    @classmethod
    def setUpClass(cls):
        init_checker('mobile_base_nodelet_manager')
        cls.lock = threading.Lock()
        cls.cmds, cls.ns_cmds, cls.leds, cls.sounds, cls.logs = \
            [], [], [], [], []
        cls.decision = None
        cls.pose = [0.0, 0.0, 0.0]            # x, y, yaw
        cls.twist = (0.0, 0.0)
        sub = rospy.Subscriber
        observers = [sub('/mobile_base/commands/velocity', Twist,
                         cls.on_cmd, queue_size=1000)]
        sub('/lab1/mobile_base/commands/velocity', Twist, cls.rec,
            'ns_cmds')
        for led in ('led1', 'led2'):
            sub('/mobile_base/commands/' + led, KobukiLed, cls.rec, 'leds')
        sub('/mobile_base/commands/sound', KobukiSound, cls.rec, 'sounds')
        observers.append(sub('/lab1/decision', Decision,
                             lambda m: setattr(cls, 'decision', m)))
        cls.rosout = sub('/rosout', Log, lambda m: cls.logs.append(m)
                         if m.name == '/lab1/dj_rob' else None,
                         queue_size=100)
        threading.Thread(target=cls.base, daemon=True).start()
        publish_constant_samples({'a': 2.0, 'b': 1.0}, observers=observers)
        cls.wait_round()

    @classmethod
    def rec(cls, msg, key):
        with cls.lock:
            getattr(cls, key).append((time.time(), msg))

    @classmethod
    def on_cmd(cls, msg):
        cls.rec(msg, 'cmds')
        cls.twist = (msg.linear.x, msg.angular.z)

    @classmethod
    def base(cls):
        """/odom at 50 Hz, integrating the last command (as the base's
        odometry would), once DJ Rob's log reaches this node (its first
        odometry message is logged)."""
        deadline = time.time() + 30.0
        while time.time() < deadline and not any(
                c.callerid_pub == '/lab1/dj_rob'
                for c in cls.rosout.impl.connections):
            time.sleep(0.05)
        pub = rospy.Publisher('/odom', Odometry, queue_size=10)
        rate, dt = rospy.Rate(50), 0.02
        while not rospy.is_shutdown():
            v, w = cls.twist
            p = cls.pose
            p[2] += w * dt
            p[0] += v * math.cos(p[2]) * dt
            p[1] += v * math.sin(p[2]) * dt
            msg = Odometry()
            msg.header.stamp = rospy.Time.now()
            msg.header.frame_id, msg.child_frame_id = 'odom', 'base_footprint'
            msg.pose.pose.position.x, msg.pose.pose.position.y = p[0], p[1]
            msg.pose.pose.orientation = Quaternion(
                0.0, 0.0, math.sin(p[2] / 2), math.cos(p[2] / 2))
            msg.twist.twist.linear.x, msg.twist.twist.angular.z = v, w
            with closed_at_shutdown():
                pub.publish(msg)
                rate.sleep()

    @classmethod
    def wait_round(cls):
        """Until the gesture's sound came and the commands stopped for
        2 s (the gesture takes about 6 s), or a timeout."""
        deadline = time.time() + 100.0
        while time.time() < deadline:
            time.sleep(0.5)
            with cls.lock:
                done = cls.sounds and cls.cmds and \
                    time.time() - cls.cmds[-1][0] > 2.0
            if done:
                break

    def test_1_the_classes_are_kobuki_msgs(self):
        for cls, ours in ((KobukiLed, Led), (KobukiSound, Sound)):
            self.assertEqual(cls._md5sum, KOBUKI_MD5[cls._type])
            self.assertEqual(cls._md5sum, ours._md5sum)
            self.assertNotEqual(cls._type, ours._type)

    def test_2_velocity_on_the_bases_topic(self):
        self.assertIsNotNone(self.decision, 'no decision')
        self.assertEqual((self.decision.outcome, self.decision.winner),
                         (Decision.WINNER, 1))
        with self.lock:
            cmds = [m for _, m in self.cmds]
            ns_cmds = list(self.ns_cmds)
        self.assertGreater(len(cmds), 50)
        self.assertTrue(any(abs(m.angular.z) > 0.1 for m in cmds))
        last = cmds[-1]
        self.assertEqual((last.linear.x, last.angular.z), (0.0, 0.0))
        self.assertEqual(ns_cmds, [], 'commands left in the namespace')

    def test_3_leds_and_sound_arrive_as_kobuki_msgs(self):
        with self.lock:
            leds, sounds = list(self.leds), list(self.sounds)
        self.assertTrue(leds, 'no LED command')
        self.assertTrue(sounds, 'no sound command')
        for _, m in leds + sounds:
            self.assertIn(m._type, KOBUKI_MD5)
            self.assertEqual(m._connection_header['type'],
                             'hri_sync/' + m._type.split('/')[1])
        self.assertIn(KobukiLed.GREEN, [m.value for _, m in leds])
        self.assertEqual(leds[-1][1].value, KobukiLed.BLACK)
        self.assertIn(KobukiSound.CLEANINGEND, [m.value for _, m in sounds])

    def test_4_dj_rob_took_the_odometry(self):
        texts = [m.msg for m in self.logs]
        self.assertTrue(any('start pose from /odom' in t for t in texts),
                        texts)
        bad = [t for t in texts if 'odom' in t.lower() and (
            'dead reckoning' in t or 'reject' in t)]
        self.assertEqual(bad, [])


if __name__ == '__main__':
    rostest.rosrun('hri_sync', 'real_base_check', RealBase)
