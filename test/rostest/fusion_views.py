#!/usr/bin/python3
"""Three views of one dancer for the fusion rostests, with one fault.

Publishes /<view>/skeleton (hri_sync/Skeleton, 30 Hz, stamped 20 ms
before now, joints of data/motion ~motion seen from each view's pose in
~poses, 1 cm noise) and /<view>/clock_state (ok, 0.5 ms). ~fault, on
view ~faulty from ~fault_after s (and 1 s at least after the fusion
listens to every view): ``stall`` (it stops), ``not_tracking`` (it
stops, and its tracker's /<view>/tracker/sensor_status says, each
second, that it tracks no one: the person left its range),
``clock_lost`` (its ClockState is not ok), ``wrong_pose`` (it is seen
from its pose moved ~wrong_shift m along x and turned ~wrong_turn
degrees, default 0.3 and 10; the fusion keeps the declared one),
``nan_joints`` (every skeleton has NaN hands), ``frozen`` (it sends its
skeleton of ~fault_after s again and again, freshly stamped, as a Kinect
SDK repeats its last one), or ``none``.  In the
CM's calibration window (/calibration/capture_data, global time: this
machine's clock, which the time server serves) the dancer stands still
and goes on from the same pose after it.
"""
import math
import os
import time

import numpy as np
import rospy
from diagnostic_msgs.msg import DiagnosticStatus
from geometry_msgs.msg import Point

from hri_sync.dance_off.motion import load_motion
from hri_sync.fusion.frames import SensorPose, parse_pose
from hri_sync.msg import CaptureData, ClockState, Skeleton
from hri_sync.wire.protocol import Capture
from hri_sync.ros.node import init_checker

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__))))
ORIGINAL = SensorPose(2.5, 0.0, 1.0, math.pi)   # the motion's own sensor


def clock_state(view, ok):
    return ClockState(client_id=view, ok=ok, reason='' if ok else 'lost',
                      local_ref=time.time(), uncertainty=0.0005, samples=5)


def main():
    init_checker('fusion_views')
    motion = load_motion(os.path.join(ROOT, 'data', 'motion', '%s.track'
                                      % rospy.get_param('~motion')))
    poses = {v: parse_pose(p) for v, p in rospy.get_param('~poses').items()}
    fault, faulty = rospy.get_param('~fault'), rospy.get_param('~faulty')
    after = rospy.get_param('~fault_after', 4.0)
    seen = dict(poses)
    if fault == 'wrong_pose':
        p = poses[faulty]
        seen[faulty] = SensorPose(
            p.x + rospy.get_param('~wrong_shift', 0.3), p.y, p.z,
            p.yaw + math.radians(rospy.get_param('~wrong_turn', 10.0)))
    pubs = {v: rospy.Publisher('/%s/skeleton' % v, Skeleton, queue_size=30)
            for v in poses}
    clocks = {v: rospy.Publisher('/%s/clock_state' % v, ClockState,
                                 queue_size=1, latch=True) for v in poses}
    for v in poses:
        clocks[v].publish(clock_state(v, True))
    status = rospy.Publisher('/%s/tracker/sensor_status' % faulty,
                             DiagnosticStatus, queue_size=1, latch=True)
    said = 0.0
    pauses = []     # [t0, t1) host time: the calibration window's, widened

    def on_calibration(msg):
        order = Capture.from_msg(msg)
        pauses.append((order.start - 0.2, order.end + 0.2))
    rospy.Subscriber('/calibration/capture_data', CaptureData,
                     on_calibration)
    rng = np.random.default_rng(36)
    start, lost, still = time.time(), False, None
    # On a busy machine the fusion's node can start after ~fault_after s: a
    # view stalled before the fusion heard it would read no_data, not
    # stalled. The fault then waits for the fusion; the dancer does not.
    fault_at = None
    rate = rospy.Rate(30)
    while not rospy.is_shutdown():
        if fault_at is None and \
                min(p.get_num_connections() for p in pubs.values()) > 0:
            fault_at = max(start + after, time.time() + 1.0)
        stamp = time.time() - 0.02
        late = fault_at is not None and time.time() > fault_at
        held = sum(min(max(stamp - a, 0.0), b - a) for a, b in pauses)
        world = ORIGINAL.to_world(motion.positions_at(
            [stamp - start - held])[0])
        for v, pub in pubs.items():
            bad = late and v == faulty
            if bad and fault == 'not_tracking' and time.time() - said > 1.0:
                status.publish(DiagnosticStatus(
                    level=DiagnosticStatus.WARN, name='tracker',
                    message="not tracking: too far / partial view: the body "
                    "is cut by the sensor's range (4.93 m) over 0.26 m"))
                said = time.time()
            if bad and fault in ('stall', 'not_tracking'):
                continue
            if bad and fault == 'clock_lost' and not lost:
                clocks[v].publish(clock_state(v, False))
                lost = True
            pts = seen[v].from_world(world) + rng.normal(0, 0.01, (15, 3))
            if bad and fault == 'frozen':
                still = pts if still is None else still
                pts = still
            if bad and fault == 'nan_joints':
                pts[7:9] = math.nan
            msg = Skeleton(client_id=v, user_id=1)
            msg.header.stamp = msg.device_stamp = rospy.Time.from_sec(stamp)
            msg.header.frame_id = '%s_sensor' % v
            msg.positions = [Point(*p) for p in pts]
            for q in msg.orientations:
                q.w = 1.0
            msg.confidence = [0.9] * 15
            pub.publish(msg)
        rate.sleep()


if __name__ == '__main__':
    main()
