#!/usr/bin/env python3
"""Make bags of other trackers' skeleton formats from data/motion.

For the adapter rostests (nodes/skeleton_adapter): a dancer
(cmu_60_01_salsa) sampled at 20 Hz with 3 mm white tracker noise
(hri_sync.dance_off.skeleton_source), 40 s, stamped from 1000 s, as

  tracker_openni   openni_tracker: one /tf message per joint, frames
                   head_1 ... right_foot_1 under openni_depth_frame, each
                   stamped when sent (20 us apart)
  tracker_azure    the Azure Kinect ROS driver: /body_tracking_data
                   MarkerArrays, marker id = body id x 100 + k4abt joint,
                   32 joints in depth_camera_link (x right, y down, z
                   forward): the dancer is body 0; body 1 a second dancer
                   (cmu_61_01_salsa) 3.5 m to the sensor's left, a
                   bystander outside the test's participant zone
  tracker_rep155   a REP 155 body tracker: a /tf message per frame with
                   the body_<id> tree (human_description links) of body
                   'dncr1' under camera_link (REP 103 axes)

Deterministic (fixed seeds). Needs ``rosbags`` (.venv/bin/python).
"""
import argparse
import os
import sys

import numpy as np
from rosbags.rosbag1 import Writer
from rosbags.typesys import get_types_from_msg

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, 'src'))
sys.path.insert(0, os.path.join(ROOT, 'scripts'))

from hri_sync.dance_off.motion import load_motion  # noqa: E402
from hri_sync.dance_off.skeleton_source import (SkeletonSource,  # noqa: E402
                                                tick_times)
from hri_sync.people.adapters import (azure_markers,  # noqa: E402
                                      openni_transforms)
from hri_sync.people.rep155 import body_transforms  # noqa: E402
from make_test_bags import MAX_BYTES, ros_time, typestore  # noqa: E402

# tf2_msgs/TFMessage (not in rosbags' ROS1 store): its definition.
TF_MESSAGE = 'geometry_msgs/TransformStamped[] transforms\n'

BASE = 1000.0       # s: the first frame's stamp (a device clock from > 0)
CASES = ('tracker_openni', 'tracker_azure', 'tracker_rep155')


def frames(dur, rate=20.0, seed=11, clip='cmu_60_01_salsa'):
    motion = load_motion(os.path.join(ROOT, 'data', 'motion',
                                      clip + '.npz'))
    source = SkeletonSource(motion, noise=0.003, seed=seed)
    return source.frames(tick_times(0.0, 0.01, rate, 0.0, dur), 0.0)


def ns(stamp):
    """A bag record time (ns) of ``stamp`` s."""
    return int(round(stamp * 1e9))


def transform(store, t, parent, child, xyz, q=(0.0, 0.0, 0.0, 1.0)):
    T = store.types
    return T['geometry_msgs/msg/TransformStamped'](
        header=T['std_msgs/msg/Header'](seq=0, stamp=ros_time(store, t),
                                        frame_id=parent),
        child_frame_id=child,
        transform=T['geometry_msgs/msg/Transform'](
            translation=T['geometry_msgs/msg/Vector3'](
                x=float(xyz[0]), y=float(xyz[1]), z=float(xyz[2])),
            rotation=T['geometry_msgs/msg/Quaternion'](
                x=float(q[0]), y=float(q[1]), z=float(q[2]), w=float(q[3]))))


def write(path, case, f, store, other=None):
    T = store.types
    tf_type = 'tf2_msgs/msg/TFMessage'
    if os.path.exists(path):
        os.remove(path)
    writer = Writer(path)
    writer.set_compression(Writer.CompressionFormat.BZ2)
    with writer:
        if case == 'tracker_azure':
            conn = writer.add_connection(
                '/body_tracking_data', 'visualization_msgs/msg/MarkerArray',
                typestore=store)
        else:
            conn = writer.add_connection('/tf', tf_type, typestore=store)
        for k, t0 in enumerate(f.stamps):
            t = BASE + t0
            p = f.positions[k]
            if case == 'tracker_openni':
                for j, (child, xyz) in enumerate(openni_transforms(1, p)):
                    tj = t + j * 20e-6
                    msg = T[tf_type](transforms=[transform(
                        store, tj, 'openni_depth_frame', child, xyz)])
                    writer.write(conn, ns(tj),
                                 store.serialize_ros1(msg, tf_type))
            elif case == 'tracker_rep155':
                msg = T[tf_type](transforms=[
                    transform(store, t, parent or 'camera_link', child, xyz,
                              q)
                    for parent, child, xyz, q in body_transforms(
                        'dncr1', p, 'rep103')])
                writer.write(conn, ns(t), store.serialize_ros1(msg, tf_type))
            else:
                markers = []
                bodies = azure_markers(0, p)
                if other is not None:
                    bodies += azure_markers(1, other.positions[k]
                                            + [-3.5, 0.0, 0.0])
                for mid, xyz in bodies:
                    markers.append(T['visualization_msgs/msg/Marker'](
                        header=T['std_msgs/msg/Header'](
                            seq=0, stamp=ros_time(store, t),
                            frame_id='depth_camera_link'),
                        ns='', id=mid, type=2, action=0,
                        pose=T['geometry_msgs/msg/Pose'](
                            position=T['geometry_msgs/msg/Point'](
                                x=float(xyz[0]), y=float(xyz[1]),
                                z=float(xyz[2])),
                            orientation=T['geometry_msgs/msg/Quaternion'](
                                x=0.0, y=0.0, z=0.0, w=1.0)),
                        scale=T['geometry_msgs/msg/Vector3'](
                            x=0.05, y=0.05, z=0.05),
                        color=T['std_msgs/msg/ColorRGBA'](
                            r=0.0, g=0.0, b=1.0, a=1.0),
                        lifetime=T['builtin_interfaces/msg/Duration'](
                            sec=0, nanosec=250000000),
                        frame_locked=False, points=[], colors=[], text='',
                        mesh_resource='', mesh_use_embedded_materials=False))
                msg = T['visualization_msgs/msg/MarkerArray'](markers=markers)
                writer.write(conn, ns(t), store.serialize_ros1(
                    msg, 'visualization_msgs/msg/MarkerArray'))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--out', default=os.path.join(ROOT, 'test', 'bags'))
    parser.add_argument('--dur', type=float, default=40.0)
    parser.add_argument('cases', nargs='*', default=list(CASES))
    args = parser.parse_args()
    store = typestore()
    store.register(get_types_from_msg(TF_MESSAGE, 'tf2_msgs/msg/TFMessage'))
    f = frames(args.dur)
    other = frames(args.dur, seed=12, clip='cmu_61_01_salsa')
    status = 0
    for case in args.cases:
        if case not in CASES:
            sys.exit('make_tracker_bags: unknown case %r (known: %s)'
                     % (case, ', '.join(CASES)))
        path = os.path.join(args.out, case + '.bag')
        write(path, case, f, store, other)
        size = os.path.getsize(path)
        print('%s: %d frames -> %s (%.0f kB)' % (
            case, len(f.stamps), os.path.relpath(path, ROOT), size / 1024.0))
        if size > MAX_BYTES:
            print('make_tracker_bags: %s is over 2 MB' % path,
                  file=sys.stderr)
            status = 1
    sys.exit(status)


if __name__ == '__main__':
    main()
