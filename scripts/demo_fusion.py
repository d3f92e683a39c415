#!/usr/bin/python3
"""The fusion demo, live: three virtual Kinects on skewed clocks, fused.

Writes the motion as each view's sensor sees it (left, right, back:
launch/demo_fusion.launch's poses) and runs that launch file with an epoch
a few seconds ahead, so that every virtual Kinect shows the dancer at the
same true instant whenever its client started. It prints each view's and
the fused body's joint error against the motion, the bodies that are
nobody, and the latency; --out keeps them as JSON.

    scripts/demo_fusion.py [--motion data/motion/cmu_60_01_salsa.track]
        [--seconds 15] [--out scores.json] [--markers]

Needs the built workspace sourced (source WS/devel/setup.bash).
"""
import argparse
import os
import subprocess
import sys
import tempfile
import time
from xml.etree import ElementTree

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, 'src'))

from hri_sync.dance_off.motion import Motion, load_motion  # noqa: E402
from hri_sync.fusion.frames import SensorPose  # noqa: E402
from hri_sync.fusion.truth import world_motion  # noqa: E402

LAUNCH = os.path.join(ROOT, 'launch', 'demo_fusion.launch')
LEAD = 12.0     # s from now to the motion's start: the launch starts


def view_poses(launch=LAUNCH):
    """{view: SensorPose} of the launch file's ``VIEW_pose`` args
    ("x y z yaw"), the one place the demo's views are set."""
    poses = {}
    for arg in ElementTree.parse(launch).getroot().iter('arg'):
        name = arg.get('name', '')
        if name.endswith('_pose') and arg.get('default'):
            poses[name[:-len('_pose')]] = SensorPose(
                *map(float, arg.get('default').split()))
    return poses


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--motion', default=os.path.join(
        ROOT, 'data', 'motion', 'cmu_60_01_salsa.track'))
    ap.add_argument('--seconds', type=float, default=15.0,
                    help='s scored, from 4 s after the motion starts')
    ap.add_argument('--out', default='', help='the scores as JSON')
    ap.add_argument('--markers', action='store_true',
                    help="rviz markers of the views and the fused body")
    ap.add_argument('--options', default='res=320x240&noise=kinect1&fps=15',
                    help='virtual Kinect URI options (docs/tracker.md); on '
                    'two cores three trackers at 30 fps lose frames')
    ap.add_argument('--profile', default='',
                    help="the trackers' profile (default: the one measured "
                    "at the views' fps, 15 or 30)")
    args = ap.parse_args()
    profile = args.profile or os.path.join(
        ROOT, 'config', 'fusion_depth_tracker%s.yaml'
        % ('_15fps' if 'fps=15' in args.options.split('&') else ''))
    world = world_motion(load_motion(args.motion))
    with tempfile.TemporaryDirectory(prefix='hri_sync_demo_fusion_') as d:
        for name, pose in view_poses().items():
            Motion(world.times, pose.from_world(world.positions)).save_track(
                os.path.join(d, name + '.track'))
        epoch = time.time() + LEAD
        print('three virtual Kinects show %s from %.1f s from now; scored '
              'from 4 s after for %.0f s' % (os.path.basename(args.motion),
                                              LEAD, args.seconds))
        status = subprocess.call([
            'roslaunch', 'hri_sync', 'demo_fusion.launch', 'tracks:=' + d,
            'motion:=' + os.path.abspath(args.motion),
            'epoch:=%.3f' % epoch, 'seconds:=%g' % args.seconds,
            'options:=' + args.options,
            'profile:=' + os.path.abspath(profile),
            'markers:=%s' % str(args.markers).lower(),
            'out:=' + (os.path.abspath(args.out) if args.out else '')])
    if status == 0:
        print('\ndemo-fusion: done. roslaunch\'s "REQUIRED process '
              '[fusion_truth-N] has died ... finished cleanly" above is how '
              'the demo ends: fusion_truth printed its table, then stopped '
              'the launch.')
    else:
        print('\ndemo-fusion: roslaunch exited with status %d: see its '
              'output above.' % status)
    return status


if __name__ == '__main__':
    sys.exit(main())
