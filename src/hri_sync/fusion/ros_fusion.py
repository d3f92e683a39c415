"""The fusion node on ROS: skeletons and clock states in, fused people out.

The executable is ``nodes/fusion``; docs/fusion.md. Under
``/use_sim_time`` (a recording played with ``rosbag play --clock``) its
host clock is the played one: the recorder's, through the recorded
``~clock_state`` if given, as ``fuse_bag`` runs.
"""
import threading
import time

import diagnostic_updater
import numpy as np
import rospy
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import Point, Point32, Quaternion
from sensor_msgs.msg import ChannelFloat32, PointCloud

from hri_sync.fusion.feed import (
    SKELETON, VIEW_CLOCK, VIEW_STATUS, VIEW_TOPICS, add_skeleton,
    clock_model, stamp_uncertainty, to_global)
from hri_sync.fusion.frames import parse_pose
from hri_sync.fusion.pipeline import Fusion
from hri_sync.fusion.profile import profiles
from hri_sync.fusion.report import VIEW, statuses
from hri_sync.fusion.settings import fusion_params
from hri_sync.msg import ClockState, Skeleton
from hri_sync.ros.outbox import closed_at_shutdown
from hri_sync.ros.params import ParamError, csv_list, param, positive


class FusionNode:
    """Skeletons and clock states in, fused people out."""

    def __init__(self):
        self.views = csv_list(param('views', None, None, None, 'view ids'))
        poses = param('poses', None, dict, None, '{view: "x y z yaw"}')
        try:
            self.poses = {v: parse_pose(poses[v]) for v in self.views}
            self.output_pose = parse_pose(param('output_pose', str(
                poses[self.views[0]])))
            profile = profiles(param('profile', {}, dict), self.views)
        except (KeyError, ValueError) as e:
            raise ParamError('%s: ~poses, ~output_pose or ~profile: %s'
                             % (rospy.get_name(), e))
        self.client_id = param('client_id', 'fused', str, bool, 'an id')
        self.world = param('world_frame', 'world', str, bool, 'a frame')
        self.extra = param('stamp_uncertainty', 0.001, float,
                           lambda x: x >= 0, '>= 0 s')
        try:
            params = fusion_params(param)
        except ValueError as e:
            raise ParamError('%s: ~%s' % (rospy.get_name(), e))
        self.sim = bool(rospy.get_param('/use_sim_time', False))
        self.lock = threading.Lock()
        self.host = None             # this host's clock model, if any
        # each view's stamps' uncertainty, from its last ClockState
        self.uncertainty_of = {v: self.extra for v in self.views}
        self.last = None
        self.fusion = Fusion(self.poses, params, lambda: self.now(), profile)
        self.skel_pub = rospy.Publisher('skeleton', Skeleton, queue_size=30)
        self.joint_pub = rospy.Publisher('joints', PointCloud, queue_size=30)
        host = self.host_topic = param('clock_state', '', str)
        if host:
            rospy.Subscriber(host, ClockState, self.on_host_clock)
        for v in self.views:
            rospy.Subscriber(param('skeleton_topic', VIEW_TOPICS[SKELETON])
                             % v, Skeleton, self.on_skeleton, v,
                             queue_size=100)
            rospy.Subscriber(param('clock_topic', VIEW_TOPICS[VIEW_CLOCK])
                             % v, ClockState, self.on_clock, v)
            rospy.Subscriber(param('status_topic', VIEW_TOPICS[VIEW_STATUS])
                             % v, DiagnosticStatus, self.on_status, v)
        self.updater = diagnostic_updater.Updater()
        self.updater.setHardwareID(self.client_id)
        for name in [VIEW + v for v in sorted(self.views)] + [
                'calibration', 'people']:
            self.updater.add(name, lambda stat, n=name: self.status(stat, n))
        rospy.Timer(rospy.Duration(param('poll_period', 0.005, float,
                                         positive)), self.poll)
        rospy.Timer(rospy.Duration(1.0), lambda _: self.updater.update())

    def now(self):
        """This host's clock (or the played one) on the global clock."""
        return to_global(rospy.get_rostime().to_sec() if self.sim
                         else time.time(), self.host)

    def on_host_clock(self, msg):
        try:
            self.host = clock_model(msg)
        except (TypeError, ValueError) as e:  # the last usable one stays
            rospy.logerr_throttle(10.0, '%s: ClockState on %s left out: %s'
                                  % (rospy.get_name(), self.host_topic, e))

    def on_clock(self, msg, view):  # its uncertainty: the next skeletons'
        self.uncertainty_of[view] = stamp_uncertainty(msg, self.extra)

    def on_status(self, msg, view):  # its tracker tracking no one
        with self.lock:
            self.fusion.sensor_said(view, msg.level, msg.message)

    def on_skeleton(self, msg, view):
        if self.sim and rospy.get_rostime().is_zero():
            rospy.logwarn_throttle(5.0, '%s: /use_sim_time and no /clock '
                                   'yet: skeletons are judged ahead of it'
                                   % rospy.get_name())
        with self.lock:
            add_skeleton(self.fusion, view, msg, self.uncertainty_of[view])
        self.poll(None)

    def poll(self, _event):
        if rospy.is_shutdown() or (self.sim and
                                   rospy.get_rostime().is_zero()):
            return
        with self.lock:
            frames = self.fusion.poll()
        with closed_at_shutdown():
            for frame in frames:
                self.publish(frame)
                self.last = frame

    def publish(self, frame):
        skeletons, cloud = fused_messages(
            frame, to_global(frame.stamp, self.host, back=True),
            self.output_pose, self.client_id, self.world)
        for msg in skeletons:
            self.skel_pub.publish(msg)
        self.joint_pub.publish(cloud)

    def status(self, stat, name):
        with self.lock:
            _, level, message, values = next(
                s for s in statuses(self.fusion, self.last) if s[0] == name)
        stat.summary(level, message)
        for key, value in values:
            stat.add(key, value)
        return stat


def fused_messages(frame, host_stamp, output_pose, client_id, world):
    """A fused frame as ROS messages: a hri_sync/Skeleton per person (in
    the frame ``client_id``_sensor of a virtual sensor at
    ``output_pose``; ``device_stamp`` the instant on the host clock,
    ``host_stamp``) and the sensor_msgs/PointCloud of every joint in
    ``world`` (channels person, joint, confidence, bound_95_m,
    newest_after_s)."""
    stamp = rospy.Time.from_sec(frame.stamp)
    device = rospy.Time.from_sec(host_stamp)
    cloud = PointCloud()
    cloud.header.stamp, cloud.header.frame_id = stamp, world
    channels = {n: [] for n in ('person', 'joint', 'confidence',
                                'bound_95_m', 'newest_after_s')}
    skeletons = []
    for person in frame.people:
        body = person.body
        found = np.isfinite(body.positions).all(axis=1)
        placed = np.where(found[:, None], body.positions,
                          np.nanmean(body.positions, axis=0))
        msg = Skeleton(client_id=client_id, user_id=person.person,
                       positions=[Point(*p) for p in
                                  output_pose.from_world(placed)],
                       sources=list(body.views))
        msg.header.stamp, msg.device_stamp = stamp, device
        msg.header.frame_id = client_id + '_sensor'
        msg.orientations = [Quaternion(w=1.0) for _ in range(15)]
        msg.confidence = [float(c) for c in body.confidence]
        skeletons.append(msg)
        for j in np.flatnonzero(found):
            cloud.points.append(Point32(*body.positions[j]))
            for name, value in zip(channels, (
                    person.person, j, body.confidence[j], body.bound[j],
                    person.newest - frame.stamp)):
                channels[name].append(float(value))
    cloud.channels = [ChannelFloat32(n, v) for n, v in channels.items()]
    return skeletons, cloud
