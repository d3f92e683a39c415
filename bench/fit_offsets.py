#!/usr/bin/python3
"""Fit a tracker profile's joint offsets to another skeleton's joints.

A profile's offsets and depth offsets (hri_sync.fusion.profile) say where
the tracker places each joint against the truth it was measured on; the
package's profile is measured on the development clip, whose truth is a
motion-capture skeleton's. Renders each MOTION (real recordings of
another skeleton's joints, as scripts/real_skeleton_motion.py converts
them: the Kinect SDK's) from --views sensors with noise seed 1, measures
the profile on it as ``bench/fusion_accuracy.py --fit-profile`` does,
each view's left and right first put the truth's way (a view that took
the back for the front is measured on the joints it meant) and each
joint's offsets the median of its errors over the view-frames (a hand a
view cannot see, 0.2-0.3 m off, weighs no more than any other miss: the
mean put the hands 3-4 cm nearer each sensor), and writes
--profile with its ``offsets`` and ``depth`` the mean of the motions'
(each motion weighs the same; the profile's other lines unchanged) to
--out. Prints JSON: each motion's view-frames whose sides were put the
truth's way, and the offsets before and after.

    bench/fit_offsets.py --motion data/motion/real/precog_Seq*.npz \\
        --out config/fusion_depth_tracker_kinect_sdk.yaml
    bench/fit_posture.py --motion data/motion/real/precog_Seq*.npz \\
        --profile config/fusion_depth_tracker_kinect_sdk.yaml

(the second puts the elbows' posture of the same people in).

Needs the built workspace sourced.
"""
import argparse
import json
import os
import sys

import numpy as np
import yaml

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)

import fusion_accuracy as fa  # noqa: E402
from profile_block import with_block  # noqa: E402
from hri_sync.fusion.profile import Profile  # noqa: E402


def measured(motion, views, base, cache):
    """The profile measured on ``motion`` (``views`` renders, seed 1) and
    how many view-frames had their sides put the truth's way."""
    args = fa.arguments(['--motion', motion, '--views', str(views),
                         '--cache', cache, '--scene', 'noise=kinect1&seed=1'])
    dumps, poses = fa.rendered_views(
        args, [fa.world_motion(fa.load_motion(motion))])
    rendered = [fa.read_dump(d) for d in dumps]
    exchanged = []
    profile = fa.fitted_profile(
        rendered, poses, lambda t: fa.truth_at(rendered, poses, t),
        base.filter, exchanged, np.nanmedian)
    return profile, exchanged[0]


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--motion', nargs='+', required=True,
                    help='the motions (.npz of real recordings)')
    ap.add_argument('--views', type=int, default=4, choices=(2, 3, 4))
    ap.add_argument('--profile', default=fa.PROFILE,
                    help='the profile written again (default %(default)s)')
    ap.add_argument('--cache', default='/tmp/hri_sync_fusion')
    ap.add_argument('--out', required=True, help='the profile written')
    args = ap.parse_args()
    with open(args.profile) as f:
        text = f.read()
    base = Profile.from_dict(yaml.safe_load(text))
    fitted, exchanged = [], {}
    for motion in args.motion:
        profile, n = measured(motion, args.views, base, args.cache)
        fitted.append(profile)
        exchanged[os.path.basename(motion)] = n
    offsets = np.round(np.mean([p.offsets for p in fitted], axis=0), 4)
    depth = np.round(np.mean([p.depth for p in fitted], axis=0), 4)
    command = ' '.join(['bench/fit_offsets.py'] + sys.argv[1:])
    text = with_block(text, 'offsets', offsets.tolist(), [
        "Joint offsets and depth offsets to another skeleton's joints",
        '(not as above: the mean of each motion\'s), fitted with',
        '  ' + command])
    text = with_block(text, 'depth', depth.tolist(), [
        'Depth offsets, fitted with the offsets above'])
    with open(args.out, 'w') as f:
        f.write(text)
    print(json.dumps({'exchanged_view_frames': exchanged, 'views': args.views,
                      'offsets_before_m': np.round(base.offsets, 4).tolist(),
                      'offsets_m': offsets.tolist(),
                      'depth_before_m': np.round(base.depth, 4).tolist(),
                      'depth_m': depth.tolist()}, indent=1))


if __name__ == '__main__':
    main()
