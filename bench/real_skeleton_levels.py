#!/usr/bin/env python3
"""Expressiveness of real Kinect skeleton streams against min_expressiveness.

Prints JSON: for each bag case of scripts/convert_real_skeleton.py, the
score of a 5 s window of its replay (forward, backward..., at its recorded
gaps, as skeleton_sensor ~bag replays it in the rostests), and over every
recording of ../shared/data/real_skeleton (--src) the distribution of
2 s window scores (every 0.5 s), with the calm stretch and the gestures'
ratios to the threshold (default 1.0 m^2/s^2).
"""
import argparse
import glob
import json
import os
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, 'src'))
sys.path.insert(0, os.path.join(ROOT, 'scripts'))

from hri_sync.dance_off.expressiveness import expressiveness  # noqa: E402
from hri_sync.dance_off.skeleton_source import replay_schedule  # noqa: E402
from hri_sync.people.kinect_csv import (read_kinect_v1,  # noqa: E402
                                        read_kinect_v2)
from convert_real_skeleton import CASES, DEFAULT_SRC, load  # noqa: E402


def replay_score(rec, dur=5.0):
    """Score of a ``dur`` s window of the recording replayed ping-pong."""
    stamps, index = [], []
    for t, i in replay_schedule(rec.stamps):
        if t >= dur:
            break
        stamps.append(t)
        index.append(i)
    res = expressiveness(stamps, rec.positions[index],
                         rec.confidence[index], duration=dur)
    return res.value


def windows(rec, width=2.0, step=0.5):
    """Scores of every ``width`` s window, ``step`` s apart."""
    out = []
    for t0 in np.arange(0.0, rec.stamps[-1] - width + 1e-9, step):
        k = (rec.stamps >= t0) & (rec.stamps < t0 + width)
        out.append(expressiveness(rec.stamps[k], rec.positions[k],
                                  rec.confidence[k], duration=width).value)
    return out


def stats(values):
    v = np.asarray(values)
    return {'n': int(v.size), 'min': float(v.min()),
            'p10': float(np.percentile(v, 10)),
            'median': float(np.median(v)), 'max': float(v.max())}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--src', default=DEFAULT_SRC)
    parser.add_argument('--threshold', type=float, default=1.0)
    args = parser.parse_args()
    out = {'threshold': args.threshold, 'bag_cases_5s_replay': {}}
    for case in sorted(CASES):
        rec = load(case, args.src)
        score = replay_score(rec)
        out['bag_cases_5s_replay'][case] = {
            'score': score, 'ratio_to_threshold': score / args.threshold,
            'frames': int(len(rec.stamps)),
            'gaps_over_50ms': int(np.sum(np.diff(rec.stamps) > 0.05)),
            'repeated_frames': int(np.sum(np.all(
                np.diff(rec.positions, axis=0) == 0, axis=(1, 2))))}
    for name, reader, pattern in (
            ('kinect_v2_2s_windows', read_kinect_v2, 'kinect2_laban/*.csv'),
            ('kinect_v1_2s_windows', read_kinect_v1,
             'kinect1_precog/*.csv')):
        per_file = {}
        for path in sorted(glob.glob(os.path.join(args.src, pattern))):
            w = windows(reader(path))
            if w:
                per_file[os.path.basename(path)] = stats(w)
        out[name] = {'per_file': per_file, 'all': stats(
            [v for s in per_file.values() for v in (s['min'], s['median'],
                                                    s['max'])])}
    print(json.dumps(out, indent=1))


if __name__ == '__main__':
    main()
