#!/usr/bin/env python3
"""Expressiveness of a still person, small movements and dancers (JSON).

Each case is sampled like a live sensor
(hri_sync.dance_off.skeleton_source: 20 Hz, own phase, white tracker
noise) for a window of --dur seconds, repeated --repeats times with
different phases and noise; prints mean, min and max of the score per
case. These numbers justify the decision module's
~min_expressiveness default (see docs/dance_off.md).

Motion comes from data/motion/*.npz (made by scripts/convert_mocap.py).
"""
import argparse
import json
import os
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, 'src'))

from hri_sync.dance_off.expressiveness import expressiveness  # noqa: E402
from hri_sync.dance_off.motion import load_motion  # noqa: E402
from hri_sync.dance_off.skeleton_source import (  # noqa: E402
    SkeletonSource, tick_times)

MOTION = os.path.join(ROOT, 'data', 'motion')


def cases(noise):
    """(label, motion file, SkeletonSource kwargs)."""
    out = []
    for sigma in sorted(set([0.002, 0.003, 0.005, 0.010, noise])):
        out.append(('still, noise %g mm' % (sigma * 1000),
                    'cmu_131_01_walk', dict(hold=0.0, noise=sigma)))
    out += [
        ('small movements: salsa at 0.3x speed from 3 s', 'cmu_60_01_salsa',
         dict(speed=0.3, offset=3.0, noise=noise)),
        ('small movements: salsa at 0.2x speed from 3 s', 'cmu_60_01_salsa',
         dict(speed=0.2, offset=3.0, noise=noise)),
        ('walk clip, 1x', 'cmu_131_01_walk', dict(noise=noise)),
    ]
    for name in ('cmu_60_01_salsa', 'cmu_61_01_salsa', 'cmu_60_04_salsa',
                 'cmu_61_04_salsa', 'cmu_60_07_salsa', 'cmu_61_07_salsa'):
        out.append(('dancer %s' % name, name, dict(noise=noise)))
    return out


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--rate', type=float, default=20.0)
    parser.add_argument('--dur', type=float, default=60.0)
    parser.add_argument('--noise', type=float, default=0.003)
    parser.add_argument('--repeats', type=int, default=10)
    args = parser.parse_args()
    rng = np.random.default_rng(1)
    results = []
    for label, name, kwargs in cases(args.noise):
        motion = load_motion(os.path.join(MOTION, name + '.npz'))
        scores = []
        for _ in range(args.repeats):
            source = SkeletonSource(motion, seed=int(rng.integers(1 << 31)),
                                    **kwargs)
            phase = rng.uniform(0, 1.0 / args.rate)
            stamps = tick_times(0.0, phase, args.rate, 0.0, args.dur)
            frames = source.frames(stamps, 0.0)
            scores.append(expressiveness(frames.stamps, frames.positions,
                                         frames.confidence,
                                         duration=args.dur).value)
        results.append({'case': label, 'motion': name,
                        'noise_m': kwargs.get('noise'),
                        'mean': round(float(np.mean(scores)), 4),
                        'min': round(float(np.min(scores)), 4),
                        'max': round(float(np.max(scores)), 4)})
    json.dump({'rate_hz': args.rate, 'dur_s': args.dur,
               'repeats': args.repeats, 'unit': 'm^2/s^2',
               'results': results}, sys.stdout, indent=1)
    print()


if __name__ == '__main__':
    main()
