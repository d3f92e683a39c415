#!/usr/bin/python3
"""Fit the fusion's posture (where people's elbows lie given their
shoulders and hands) on motion captures, into tracker profiles.

Reads each MOTION as the fusion bench places it in world
(hri_sync.fusion.truth.world_motion), keeps both arms of every frame of
them all (hri_sync.fusion.posture.fit_posture) and writes each --profile
with them as its ``posture`` block (the profile's other lines unchanged).
Prints JSON: the arms kept and the prior's error on the elbows from the
true shoulders and hands (median and 95th percentile, m) and its mean
stated error (one axis), each motion's elbows from a posture fitted on
the others (one motion: each half from the other half), with several
also by motion.

    bench/fit_posture.py --motion data/motion/cmu_60_01_salsa.npz \\
        --profile config/fusion_depth_tracker.yaml \\
        config/fusion_depth_tracker_15fps.yaml
    bench/fit_posture.py --motion data/motion/real/precog_Seq*.npz \\
        --profile config/fusion_depth_tracker_kinect_sdk.yaml
"""
import argparse
import json
import os
import sys
from typing import Dict, List

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, '..', 'src'))

from hri_sync.dance_off.motion import load_motion  # noqa: E402
from hri_sync.fusion.posture import (  # noqa: E402
    Posture, arms_in_axes, fit_posture)
from hri_sync.fusion.truth import world_motion  # noqa: E402
from profile_block import with_block  # noqa: E402


def held_out(parts: List[np.ndarray], sigma: float):
    """Each part's elbows from a posture fitted on the other parts: the
    prior's errors (m) and its stated errors (m, one axis), by part."""
    out = []
    for k, test in enumerate(parts):
        posture = fit_posture(np.concatenate(
            [p for i, p in enumerate(parts) if i != k]), sigma)
        arms = arms_in_axes(test).reshape(-1, 2, 3)
        errors, stated = [], []
        for hand, elbow in arms[np.isfinite(arms).all(axis=(1, 2))]:
            mean, var = posture.prior(hand)
            errors.append(np.linalg.norm(mean - elbow))
            stated.append(np.sqrt(var))
        out.append((np.array(errors), np.array(stated)))
    return out


def spread(errors: np.ndarray) -> Dict[str, float]:
    """Median and 95th percentile (m)."""
    return {'median': round(float(np.median(errors)), 4),
            'p95': round(float(np.percentile(errors, 95)), 4)}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--motion', required=True, nargs='+',
                    help='.bvh, .npz or .track files')
    ap.add_argument('--sigma', type=float, default=Posture.sigma,
                    help="m, one axis: the prior's error at the capture's "
                    'own poses (default %(default)s)')
    ap.add_argument('--profile', nargs='*', default=[],
                    help='tracker profiles (YAML) to write the posture into')
    args = ap.parse_args()
    motions = [world_motion(load_motion(m)).positions for m in args.motion]
    positions = np.concatenate(motions)
    posture = fit_posture(positions, args.sigma)
    half = len(positions) // 2
    checked = held_out(motions if len(motions) > 1
                       else [positions[:half], positions[half:]], args.sigma)
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
    names = [os.path.basename(m) for m in args.motion]
    report = {
        'motion': names, 'arms': len(posture.hands),
        'held_out_error_m': spread(np.concatenate([e for e, _ in checked])),
        'held_out_stated_sigma_m': round(float(np.concatenate(
            [s for _, s in checked]).mean()), 4),
        'written': args.profile}
    if len(motions) > 1:
        report['held_out_error_by_motion_m'] = {
            name: spread(e) for name, (e, _) in zip(names, checked)}
    print(json.dumps(report, indent=1))


if __name__ == '__main__':
    main()
