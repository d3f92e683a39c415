"""A simulated Kobuki base on ROS.

The executable is ``nodes/kobuki_sim``.
"""
import math
import threading

import rospy
import tf2_ros
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry

from hri_sync.msg import Led, Sound
from hri_sync.robot.geometry import quaternion_from_yaw
from hri_sync.robot.kobuki import (LED_NAMES, ODOM_COVARIANCE, SOUND_NAMES,
                                   KobukiBase, limits_from_params)
from hri_sync.ros.inbox import Inbox
from hri_sync.ros.outbox import closed_at_shutdown
from hri_sync.ros.params import ParamError, param, positive
from hri_sync.ros.transforms import transform


class KobukiSim:
    """The ROS shell of a KobukiBase."""

    def __init__(self):
        try:
            limits = limits_from_params(lambda name, default: param(
                name, default, float))
        except ValueError as e:
            raise ParamError(str(e))
        self.rate = param('rate', 50.0, float, positive, '> 0 Hz')
        self.odom_frame = param('odom_frame', 'odom', str, bool)
        self.base_frame = param('base_frame', 'base_footprint', str, bool)
        self.lock = threading.Lock()
        self.base = KobukiBase(
            start=rospy.get_time(), limits=limits,
            wheelbase=param('wheelbase', 0.23, float, positive, '> 0 m'),
            timeout=param('cmd_timeout', 0.6, float, positive, '> 0 s'),
            rate=self.rate)
        self.timeouts_logged = 0
        self.odom_pub = rospy.Publisher('odom', Odometry, queue_size=10)
        self.tf = tf2_ros.TransformBroadcaster()
        self.led_pubs = {
            name: rospy.Publisher('~' + name, Led, queue_size=1, latch=True)
            for name in ('led1', 'led2')}
        for pub in self.led_pubs.values():
            pub.publish(Led(value=Led.BLACK))
        self.sound_pub = rospy.Publisher('~sound', Sound, queue_size=10)
        self.diag_pub = rospy.Publisher('/diagnostics', DiagnosticArray,
                                        queue_size=1)
        # Commands only from the robot node (~senders: {robot: <id>}).
        self.inbox = Inbox()
        self.inbox.subscribe('mobile_base/commands/velocity', Twist,
                             self.on_velocity, 'robot', queue_size=10,
                             tcp_nodelay=True)
        for name in ('led1', 'led2'):
            self.inbox.subscribe('mobile_base/commands/' + name, Led,
                                 lambda m, n=name: self.on_led(m, n),
                                 'robot')
        self.inbox.subscribe('mobile_base/commands/sound', Sound,
                             self.on_sound, 'robot')
        rospy.Timer(rospy.Duration(1.0 / self.rate), self.on_tick)
        rospy.Timer(rospy.Duration(1.0), self.on_diagnostics)
        rospy.loginfo('kobuki_sim: %.0f Hz, limits %.2f m/s %.0f deg/s '
                      '%.2f m/s^2 %.2f rad/s^2, timeout %.2f s',
                      self.rate, limits.linear, math.degrees(limits.angular),
                      limits.linear_accel, limits.angular_accel,
                      self.base.timeout)

    def on_velocity(self, msg):
        now = rospy.get_time()
        with self.lock:
            self.base.step(now)
            try:
                self.base.command(msg.linear.x, msg.angular.z, now)
            except ValueError as e:
                rospy.logerr_throttle(1, 'kobuki_sim: command refused: %s '
                                      '(%d so far)', e, self.base.refused)
            ignored = [v for v in (msg.linear.y, msg.linear.z, msg.angular.x,
                                   msg.angular.y) if v != 0.0]
        if ignored:
            rospy.logwarn_throttle(5, 'kobuki_sim: a differential drive '
                                   'ignores linear.y/z and angular.x/y')

    def on_led(self, msg, name):
        if msg.value not in LED_NAMES:
            rospy.logerr('kobuki_sim: %s: unknown LED value %d', name,
                         msg.value)
            return
        rospy.loginfo('kobuki_sim: %s %s', name, LED_NAMES[msg.value])
        self.led_pubs[name].publish(msg)

    def on_sound(self, msg):
        if msg.value not in SOUND_NAMES:
            rospy.logerr('kobuki_sim: unknown sound value %d', msg.value)
            return
        rospy.loginfo('kobuki_sim: sound "%s"', SOUND_NAMES[msg.value])
        self.sound_pub.publish(msg)

    def on_tick(self, _event):
        now = rospy.get_time()
        with self.lock:
            s = self.base.step(now)
            timeouts = self.base.timeouts
        if timeouts > self.timeouts_logged:
            self.timeouts_logged = timeouts
            rospy.logwarn('kobuki_sim: no velocity command for %.1f s while '
                          'moving: stopping (a missing explicit zero)',
                          self.base.timeout)
        stamp = rospy.Time.from_sec(s.stamp)
        q = quaternion_from_yaw(s.theta)
        odom = Odometry()
        odom.header.stamp = stamp
        odom.header.frame_id = self.odom_frame
        odom.child_frame_id = self.base_frame
        p = odom.pose.pose
        p.position.x, p.position.y = s.x, s.y
        (p.orientation.x, p.orientation.y, p.orientation.z,
         p.orientation.w) = q
        odom.twist.twist.linear.x = s.linear
        odom.twist.twist.angular.z = s.angular
        odom.pose.covariance = odom.twist.covariance = ODOM_COVARIANCE
        tf = transform(stamp, self.odom_frame, self.base_frame,
                       (s.x, s.y, 0.0), q)
        with closed_at_shutdown():      # a tick as the node shuts down
            self.odom_pub.publish(odom)
            self.tf.sendTransform(tf)

    def on_diagnostics(self, _event):
        with self.lock:
            health = self.base.health()
        status = DiagnosticStatus(
            level=DiagnosticStatus.OK if health.ok else DiagnosticStatus.WARN,
            name='kobuki_sim: commands', hardware_id='kobuki_sim',
            message=health.message,
            values=[KeyValue(k, str(v)) for k, v in health.counters])
        msg = DiagnosticArray(status=[status])
        msg.header.stamp = rospy.Time.now()
        self.diag_pub.publish(msg)
