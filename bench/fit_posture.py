#!/usr/bin/python3
"""Fit the fusion's posture (where people's elbows lie given their
shoulders and hands) on a motion capture, into tracker profiles.

Reads MOTION as the fusion bench places it in world
(hri_sync.fusion.truth.world_motion), keeps both arms of every frame
(hri_sync.fusion.posture.fit_posture) and writes each --profile with them
as its ``posture`` block (the profile's other lines unchanged). Prints
JSON: the arms kept and, over the motion's two halves each fitted on the
other, the prior's error on the elbows from the true shoulders and hands
(median and 95th percentile, m) and its mean stated error (one axis).

    bench/fit_posture.py --motion data/motion/cmu_60_01_salsa.npz \\
        --profile config/fusion_depth_tracker.yaml \\
        config/fusion_depth_tracker_15fps.yaml
"""
import argparse
import json
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, '..', 'src'))

from hri_sync.dance_off.motion import load_motion  # noqa: E402
from hri_sync.fusion.posture import (  # noqa: E402
    Posture, arms_in_axes, fit_posture)
from hri_sync.fusion.truth import world_motion  # noqa: E402
from profile_block import with_block  # noqa: E402


def held_out(positions: np.ndarray, sigma: float):
    """Each half's elbows from a posture fitted on the other half: the
    prior's errors (m) and its stated errors (m, one axis)."""
    half = len(positions) // 2
    errors, stated = [], []
    for fit, test in ((slice(half, None), slice(None, half)),
                      (slice(None, half), slice(half, None))):
        posture = fit_posture(positions[fit], sigma)
        arms = arms_in_axes(positions[test]).reshape(-1, 2, 3)
        for hand, elbow in arms[np.isfinite(arms).all(axis=(1, 2))]:
            mean, var = posture.prior(hand)
            errors.append(np.linalg.norm(mean - elbow))
            stated.append(np.sqrt(var))
    return np.array(errors), np.array(stated)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--motion', required=True, help='.bvh, .npz or .track')
    ap.add_argument('--sigma', type=float, default=Posture.sigma,
                    help="m, one axis: the prior's error at the capture's "
                    'own poses (default %(default)s)')
    ap.add_argument('--profile', nargs='*', default=[],
                    help='tracker profiles (YAML) to write the posture into')
    args = ap.parse_args()
    positions = world_motion(load_motion(args.motion)).positions
    posture = fit_posture(positions, args.sigma)
    errors, stated = held_out(positions, args.sigma)
    command = ' '.join(['bench/fit_posture.py'] + sys.argv[1:])
    for path in args.profile:
        with open(path) as f:
            text = f.read()
        with open(path, 'w') as f:
            f.write(with_block(text, 'posture', posture.to_dict(), [
                'Where people\'s elbows lie given their shoulders and hands',
                '(hri_sync.fusion.posture; rows: hand, elbow, mm, from the',
                "shoulder in the shoulders' axes), fitted with",
                '  ' + command]))
    print(json.dumps({
        'motion': os.path.basename(args.motion), 'arms': len(posture.hands),
        'held_out_error_m': {'median': round(float(np.median(errors)), 4),
                             'p95': round(float(np.percentile(errors, 95)),
                                          4)},
        'held_out_stated_sigma_m': round(float(stated.mean()), 4),
        'written': args.profile}, indent=1))


if __name__ == '__main__':
    main()
