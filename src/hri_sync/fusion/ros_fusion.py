"""The fusion node on ROS: skeletons and clock states in, fused people out.

The executable is ``nodes/fusion``; docs/fusion.md.
"""
import math
import threading
import time

import diagnostic_updater
import numpy as np
import rospy
from geometry_msgs.msg import Point, Point32, Quaternion
from sensor_msgs.msg import ChannelFloat32, PointCloud

from hri_sync.fusion.frames import parse_pose
from hri_sync.fusion.pipeline import Fusion, FusionParams
from hri_sync.fusion.profile import profiles
from hri_sync.fusion.report import statuses
from hri_sync.msg import ClockState, Skeleton
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
        params = FusionParams(rate=param('rate', 30.0, float, positive))
        params.health.stall_after = param('stall_after', 0.5, float,
                                          positive)
        params.max_ahead = param('max_ahead', 0.2, float, positive)
        params.max_age = param('max_age', 2.0, float, positive)
        params.max_depth = param('max_depth', 10.0, float, positive)
        params.scatter_hold = param('scatter_hold', 0.5, float,
                                    lambda x: x >= 0, '>= 0 s')
        params.smooth.accel = param('smooth_accel', 30.0, float,
                                    lambda x: x >= 0, '>= 0 m/s^2')
        params.residual_threshold = param('residual_threshold', 0.2, float,
                                          positive)
        params.arms.margin = param('arms_margin', 0.2, float,
                                   lambda x: x > 0, '> 0 m (inf: never)')
        params.sight.fov_deg = param('fov_deg', 57.0, float,
                                     lambda x: 0 < x < 360, '0-360 degrees')
        params.sight.far = param('max_range', 4.5, float, positive)
        self.lock = threading.Lock()
        self.host = None             # this host's ClockState, if any
        self.clock_of = {v: None for v in self.views}
        self.last = None
        self.fusion = Fusion(self.poses, params, lambda: self.now(), profile)
        self.skel_pub = rospy.Publisher('skeleton', Skeleton, queue_size=30)
        self.joint_pub = rospy.Publisher('joints', PointCloud, queue_size=30)
        host = param('clock_state', '', str)
        if host:
            rospy.Subscriber(host, ClockState,
                             lambda msg: setattr(self, 'host', msg))
        for v in self.views:
            rospy.Subscriber(param('skeleton_topic', '/%s/skeleton') % v,
                             Skeleton, self.on_skeleton, v, queue_size=100)
            rospy.Subscriber(param('clock_topic', '/%s/clock_state') % v,
                             ClockState, self.on_clock, v)
        self.updater = diagnostic_updater.Updater()
        self.updater.setHardwareID(self.client_id)
        for name in ['view %s' % v for v in sorted(self.views)] + [
                'calibration', 'people']:
            self.updater.add(name, lambda stat, n=name: self.status(stat, n))
        rospy.Timer(rospy.Duration(param('poll_period', 0.005, float,
                                         positive)), self.poll)
        rospy.Timer(rospy.Duration(1.0), lambda _: self.updater.update())

    def now(self, local=None, back=False):
        """Global time of host time ``local`` (now) through the host's
        clock model, if any; ``back``: host time of global ``local``."""
        local, m = time.time() if local is None else local, self.host
        if m is None or not m.ok:
            return local
        if back:
            return (local - m.offset + m.drift * m.local_ref) / (1 + m.drift)
        return local + m.offset + m.drift * (local - m.local_ref)

    def on_clock(self, msg, view):  # its uncertainty: the next skeletons'
        self.clock_of[view] = msg

    def on_skeleton(self, msg, view):
        m = self.clock_of[view]
        uncertainty = self.extra + (0.0 if m is None else
                                    m.uncertainty if m.ok else math.inf)
        positions = [(p.x, p.y, p.z) for p in msg.positions]
        with self.lock:
            self.fusion.add(view, msg.user_id, msg.header.stamp.to_sec(),
                            positions, list(msg.confidence), uncertainty)
        self.poll(None)

    def poll(self, _event):
        if rospy.is_shutdown():
            return
        with self.lock:
            frames = self.fusion.poll()
        for frame in frames:
            try:
                self.publish(frame)
            except rospy.ROSException:  # publishers closed: shutting down
                if not rospy.is_shutdown():
                    raise
                return
            self.last = frame

    def publish(self, frame):
        stamp = rospy.Time.from_sec(frame.stamp)
        device = rospy.Time.from_sec(self.now(frame.stamp, True))  # host
        cloud = PointCloud()
        cloud.header.stamp, cloud.header.frame_id = stamp, self.world
        channels = {n: [] for n in ('person', 'joint', 'confidence',
                                    'bound_95_m', 'newest_after_s')}
        for person in frame.people:
            body = person.body
            found = np.isfinite(body.positions).all(axis=1)
            world = np.where(found[:, None], body.positions,
                             np.nanmean(body.positions, axis=0))
            msg = Skeleton(client_id=self.client_id, user_id=person.person,
                           positions=[Point(*p) for p in
                                      self.output_pose.from_world(world)],
                           sources=list(body.views))
            msg.header.stamp, msg.device_stamp = stamp, device
            msg.header.frame_id = self.client_id + '_sensor'
            msg.orientations = [Quaternion(w=1.0) for _ in range(15)]
            msg.confidence = [float(c) for c in body.confidence]
            self.skel_pub.publish(msg)
            for j in np.flatnonzero(found):
                cloud.points.append(Point32(*body.positions[j]))
                for name, value in zip(channels, (
                        person.person, j, body.confidence[j], body.bound[j],
                        person.newest - frame.stamp)):
                    channels[name].append(float(value))
        cloud.channels = [ChannelFloat32(n, v) for n, v in channels.items()]
        self.joint_pub.publish(cloud)

    def status(self, stat, name):
        with self.lock:
            _, level, message, values = next(
                s for s in statuses(self.fusion, self.last) if s[0] == name)
        stat.summary(level, message)
        for key, value in values:
            stat.add(key, value)
        return stat

