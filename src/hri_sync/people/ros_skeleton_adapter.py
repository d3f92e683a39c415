"""Other trackers' skeletons on ROS, as hri_sync/Skeleton.

The executable is ``nodes/skeleton_adapter``.
"""
import threading
import time

import rospy
from geometry_msgs.msg import Point, Quaternion
from tf2_msgs.msg import TFMessage
from visualization_msgs.msg import MarkerArray

from hri_sync.dance_off.joints import NUM_JOINTS
from hri_sync.msg import Skeleton
from hri_sync.people.adapters import (AzureKinectMarkers, OpenniTf,
                                      Rep155Tf)
from hri_sync.people.joint_maps import CONVENTIONS
from hri_sync.ros.diagnostics import NodeDiagnostics
from hri_sync.ros.params import ParamError, param
from hri_sync.ros.stamps import StampError, stamp

FORMATS = ('openni_tf', 'azure_kinect', 'rep155_tf')
DEFAULT_FRAME = {'openni_tf': 'openni_depth_frame',
                 'azure_kinect': 'depth_camera_link'}
DEFAULT_CONVENTION = {'azure_kinect': 'optical', 'rep155_tf': 'rep103'}


class SkeletonAdapter:
    """Reads ~params, wires a tracker's topics to an adapter."""

    def __init__(self):
        self.client_id = param('client_id', None, str, bool, 'a client id')
        fmt = param('format', None, str, lambda f: f in FORMATS,
                    ' or '.join(FORMATS))
        source = param('source_frame', DEFAULT_FRAME.get(fmt, ''), str)
        if not source:
            raise ParamError('~source_frame is required with ~format %s: '
                             'the frame body_<id> trees hang from' % fmt)
        convention = param('convention', DEFAULT_CONVENTION.get(fmt, ''),
                           str, lambda c: c in CONVENTIONS or
                           fmt == 'openni_tf', ' or '.join(CONVENTIONS))
        min_joints = param('min_joints', NUM_JOINTS, int,
                           lambda n: 1 <= n <= NUM_JOINTS,
                           'within 1..%d' % NUM_JOINTS)
        window = param('window', 0.02, float, lambda w: w > 0, '> 0 s')
        jumps = {'reject_jumps': param('reject_jumps', False, bool)}
        self.frame_id = param('frame_id', self.client_id + '_sensor', str)
        self.lock = threading.Lock()
        if fmt == 'openni_tf':
            self.adapter = OpenniTf(source, min_joints, window, **jumps)
        elif fmt == 'rep155_tf':
            self.adapter = Rep155Tf(source, convention, min_joints, window,
                                    **jumps)
        else:
            self.adapter = AzureKinectMarkers(source, convention,
                                              min_joints, **jumps)
        self.pub = rospy.Publisher('skeleton', Skeleton, queue_size=100,
                                   tcp_nodelay=True)
        self.seq = 0
        diagnostics = NodeDiagnostics(self.client_id)
        diagnostics.rejections(self.rejections)
        if fmt == 'azure_kinect':
            rospy.Subscriber('body_tracking_data', MarkerArray,
                             self.on_markers, queue_size=10)
        else:
            rospy.Subscriber('/tf', TFMessage, self.on_tf,
                             queue_size=1000, tcp_nodelay=True)
            rospy.Subscriber('/tf_static', TFMessage, self.on_tf_static,
                             queue_size=100)
            threading.Thread(target=self.poll, args=(window / 2,),
                             daemon=True).start()
        rospy.loginfo('%s: %s from %s -> %s (min_joints %d)',
                      rospy.get_name(), fmt, source,
                      rospy.resolve_name('skeleton'), min_joints)

    def rejections(self):
        """{'<source frame> <reason>': frames rejected} (a snapshot)."""
        counts = dict(self.adapter.counts)
        return {'%s %s' % (self.adapter.source_frame, why): n
                for why, n in counts.items()
                if why not in ('other_frames', 'deleted_markers',
                               'joints_missing', 'id_jumps')}

    def on_tf(self, msg, static=False):
        now = time.time()
        out = []
        with self.lock:     # held while publishing: Bodies go out in order
            for tr in msg.transforms:
                t = tr.transform.translation
                if isinstance(self.adapter, OpenniTf):
                    out += self.adapter.add(
                        tr.header.frame_id, tr.child_frame_id,
                        tr.header.stamp.to_sec(), (t.x, t.y, t.z), now)
                else:
                    q = tr.transform.rotation
                    out += self.adapter.add(
                        tr.header.frame_id, tr.child_frame_id,
                        tr.header.stamp.to_sec(), (t.x, t.y, t.z),
                        (q.x, q.y, q.z, q.w), now, static)
            self.publish(out)

    def on_tf_static(self, msg):
        self.on_tf(msg, static=True)

    def on_markers(self, msg):
        markers = [(m.id, m.header.frame_id, m.header.stamp.to_sec(),
                    (m.pose.position.x, m.pose.position.y,
                     m.pose.position.z), m.action) for m in msg.markers]
        with self.lock:
            self.publish(self.adapter.add(markers))

    def poll(self, period):
        while not rospy.is_shutdown():
            time.sleep(period)
            with self.lock:
                self.publish(self.adapter.poll(time.time()))

    def publish(self, bodies):
        """Send Bodies (called with the lock held)."""
        before = sum(self.rejections().values())
        for b in bodies:
            try:
                t = stamp(b.stamp)
            except StampError:
                self.adapter.counts['bad_stamp'] += 1
                continue
            msg = Skeleton(client_id=self.client_id, user_id=b.user_id)
            msg.header.stamp = msg.device_stamp = t
            msg.header.frame_id = self.frame_id
            msg.positions = [Point(*p) for p in b.positions]
            msg.orientations = [Quaternion(0.0, 0.0, 0.0, 1.0)
                                for _ in range(NUM_JOINTS)]
            msg.confidence = b.confidence.tolist()
            self.pub.publish(msg)
        if before:
            rospy.logwarn_throttle(5, '%s: frames rejected so far: %s',
                                   rospy.get_name(), ', '.join(
                                       '%s %d' % kv for kv in
                                       sorted(self.rejections().items())))
