#!/usr/bin/python3
"""Refines one sensor's pose from a person the other sensors see.

Reads the views' hri_sync/Skeleton topics (/<view>/skeleton) from a bag
recorded while a person walked through the shared view, brings the
view's joints and the other views' (placed by their poses) to common
instants, fits the view's yaw and position (pitch kept) and prints the
mean residual before and after and the refined pose, as the fusion
launch file's poses take it (hri_sync.fusion.calibration).

    source .ws/devel/setup.bash
    scripts/fusion_refine_pose.py --bag walk.bag --view right \
        --poses "{left: '3.3 0.4 1.0 -3.02', right: '0.5 -3.3 1.0 1.72', \
                  back: '-2.3 2.3 1.0 -0.785'}"
"""
import argparse
import math
import os
import sys

import yaml

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__))), 'src'))

from hri_sync.fusion.calibration import refine_pose, shared_points  # noqa
from hri_sync.fusion.frames import parse_pose  # noqa: E402


def read(bag_path, views, user):
    """{view: [(stamp, joints, confidence)]} of user ``user`` (0: any)."""
    import rosbag
    out = {v: [] for v in views}
    topics = {'/%s/skeleton' % v: v for v in views}
    with rosbag.Bag(bag_path) as bag:
        for topic, msg, _ in bag.read_messages():
            view = topics.get('/' + topic.lstrip('/'))
            if view is None or (user and msg.user_id != user):
                continue
            out[view].append((msg.header.stamp.to_sec(),
                              [(p.x, p.y, p.z) for p in msg.positions],
                              list(msg.confidence)))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--bag', required=True)
    ap.add_argument('--view', required=True, help='the view to refine')
    ap.add_argument('--poses', required=True,
                    help="YAML {view: 'x y z yaw [pitch]'}, every view")
    ap.add_argument('--user', type=int, default=0,
                    help='the walker\'s user_id (0: the one person seen)')
    args = ap.parse_args()
    poses = {v: parse_pose(p) for v, p in yaml.safe_load(args.poses).items()}
    if args.view not in poses or len(poses) < 2:
        sys.exit('fusion_refine_pose: --poses must hold --view and another')
    skeletons = read(args.bag, list(poses), args.user)
    others = {v: s for v, s in skeletons.items() if v != args.view and s}
    sensor, world = shared_points(skeletons[args.view], others, poses)
    if len(sensor) < 100:
        sys.exit('fusion_refine_pose: only %d joints seen by %s and another '
                 'view; record a longer walk' % (len(sensor), args.view))
    pose, before, after = refine_pose(poses[args.view], sensor, world)
    print('%s: %d shared joints; mean residual %.0f mm before, %.0f mm after'
          % (args.view, len(sensor), before * 1e3, after * 1e3))
    print("refined pose: '%.3f %.3f %.3f %.4f %.4f' (yaw %.1f deg)"
          % (pose.x, pose.y, pose.z, pose.yaw, pose.pitch,
             math.degrees(pose.yaw)))


if __name__ == '__main__':
    main()
