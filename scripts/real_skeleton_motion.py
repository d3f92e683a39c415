#!/usr/bin/env python3
"""A real Kinect skeleton recording as a motion the virtual Kinect renders.

Checks the tracker and the fusion on motion that is not in the repo:
reads a Kinect v1 PRECOG CSV or a Kinect v2 LabanotationSuite CSV
(hri_sync.people.kinect_csv) as the project's body (NiTE's 15 joints,
the tracker's model): each foot joint on its shin's line below the ankle
(the body's foot is the sole under the shin; a Kinect SDK's foot joint
lies 5-9 cm ahead of the ankle, which would render every straight leg
with its knee behind the line from the hip to the foot) and the torso
midway between the hips' centre and the neck (the Kinect v1 SDK's Spine
lies a quarter of the way up), sets the feet on the floor (their median
at ``FEET_Y`` in the motion's frame, where the development clip has
its feet) and writes a motion ``.npz`` (at the Kinect's times: v1 at
its nominal 30 Hz) for
``bench/fusion_accuracy.py --motion`` or ``bench/fusion_noise.py``:

    scripts/real_skeleton_motion.py Seq2_8.csv --out /tmp/precog_2_8.npz
    bench/fusion_noise.py --motion /tmp/precog_2_8.npz --views 4

Prints the frames, the seconds and the joints' share the Kinect tracked.
"""
import argparse
import os
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, 'src'))

from hri_sync.dance_off.joints import INDEX  # noqa: E402
from hri_sync.dance_off.motion import Motion  # noqa: E402
from hri_sync.people.kinect_csv import (given, read_kinect_v1,  # noqa: E402
                                        read_kinect_v2)

FEET_Y = -0.949     # m: the feet's median height in the development clip
FEET = [INDEX['left_foot'], INDEX['right_foot']]
KNEES = [INDEX['left_knee'], INDEX['right_knee']]
HIPS = [INDEX['left_hip'], INDEX['right_hip']]


def feet_under_shins(positions, ankles):
    """``positions`` (N, 15, 3) with each foot on its shin's line, below
    the ankle (N, 2, 3) by the recording's median drop of the SDK's foot
    along the shin."""
    shin = ankles - positions[:, KNEES]
    shin /= np.linalg.norm(shin, axis=-1, keepdims=True)
    drop = np.nanmedian(np.sum((positions[:, FEET] - ankles) * shin, axis=-1))
    out = positions.copy()
    out[:, FEET] = ankles + shin * drop
    return out


def torso_midway(positions):
    """``positions`` (N, 15, 3) with the torso midway between the hips'
    centre and the neck."""
    out = positions.copy()
    out[:, INDEX['torso']] = (positions[:, HIPS].mean(axis=1)
                              + positions[:, INDEX['neck']]) / 2
    return out


def motion_of(path, kinect):
    """The recording at ``path`` (``kinect`` 1 or 2) as a Motion of its
    frames with every joint given (a Kinect SDK gives one it does not
    track at 0 0 0), and the share of its joints the sensor tracked;
    ValueError when no frame gives every joint."""
    rec = (read_kinect_v1 if kinect == 1 else read_kinect_v2)(path)
    joints = given(rec.positions)
    whole = joints.all(axis=1) & given(rec.ankles).all(axis=1)
    if not whole.any():
        raise ValueError('%s: no frame gives every joint (the sensor '
                         'tracked no one)' % path)
    positions = torso_midway(feet_under_shins(rec.positions[whole],
                                              rec.ankles[whole]))
    positions[..., 1] += FEET_Y - np.median(positions[:, FEET, 1])
    name = os.path.splitext(os.path.basename(path))[0]
    return (Motion(rec.stamps[whole], positions, name=name),
            float(np.mean(joints & (rec.confidence >= 1.0))))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('csv', help='a Kinect skeleton CSV')
    ap.add_argument('--kinect', type=int, choices=(1, 2), default=1,
                    help='1: PRECOG (default), 2: LabanotationSuite')
    ap.add_argument('--out', required=True, help='the motion .npz')
    args = ap.parse_args()
    try:
        motion, tracked = motion_of(args.csv, args.kinect)
    except (OSError, ValueError) as e:
        sys.exit('real_skeleton_motion: %s' % e)
    motion.save_npz(args.out)
    print('%s: %d frames, %.1f s, %.0f %% of the joints tracked -> %s' % (
        args.csv, len(motion.times), motion.times[-1], 100 * tracked,
        args.out))


if __name__ == '__main__':
    main()
