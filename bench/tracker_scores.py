#!/usr/bin/python3
"""A dancer's score through the depth tracker against the rendered truth's.

Renders each motion in-process (the whole clip once, no loop) with a scene,
tracks it with the single-user tracker and scores two 10 s windows (from
2 s, and ending 0.2 s before the clip does) with the project's
expressiveness, the tracker's joints (confidence below 0.5 left out, as the
DPM does) against the truth's joints. Prints one JSON object: per clip the
windows' ratios (tracker / truth), both scores, the mean joint error and the
tracked share. The target: every ratio within 15 % of 1.

    bench/tracker_scores.py
    bench/tracker_scores.py --clips cmu_60_07_salsa:loose_clothes

Needs the built workspace sourced (source WS/devel/setup.bash).
"""
import argparse
import concurrent.futures
import importlib.util
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, 'src'))
from hri_sync.dance_off.expressiveness import expressiveness  # noqa: E402

_spec = importlib.util.spec_from_file_location(
    'tracker_still', os.path.join(ROOT, 'bench', 'tracker_still.py'))
still = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(still)
accuracy = still.accuracy

WINDOW = 10.0
# clip:body; cmu_61_04 and cmu_60_07 are kept out of tuning (checking only)
CLIPS = ('cmu_60_01_salsa:average', 'cmu_61_01_salsa:tall_slim',
         'cmu_61_04_salsa:short_broad', 'cmu_60_07_salsa:loose_clothes')


def track_of(clip, tmp):
    path = os.path.join(ROOT, 'data', 'motion', clip + '.track')
    if os.path.exists(path):
        return path
    return accuracy.to_track(os.path.join(ROOT, 'data', 'motion',
                                          clip + '.npz'), tmp)


def duration(track):
    with open(track) as f:
        last = [line for line in f if line.strip()
                and not line.startswith('#')][-1]
    return float(last.split()[0])


def run_clip(exe, spec, scene, tmp):
    clip, body = spec.split(':')
    track = track_of(clip, tmp)
    seconds = duration(track)
    dump = os.path.join(tmp, clip + '.dump')
    subprocess.run([exe, '--track', track, '--direct', '--seconds',
                    str(seconds), '--scene', 'body=%s&%s' % (body, scene),
                    '--dump', dump], check=True, capture_output=True)
    stamps, tracked, est, truth, conf = still.read_dump(dump)
    windows = []
    for start in (2.0, seconds - 0.2 - WINDOW):
        sel = tracked & (stamps >= start) & (stamps < start + WINDOW)
        got = expressiveness(stamps[sel], est[sel], conf[sel],
                             duration=WINDOW).value
        want = expressiveness(stamps[sel], truth[sel],
                              duration=WINDOW).value
        windows.append({'start_s': round(start, 2),
                        'tracker': round(got, 2), 'truth': round(want, 2),
                        'ratio': round(got / want, 3)})
    error = np.linalg.norm(est[tracked] - truth[tracked], axis=2).mean()
    return {'clip': clip, 'body': body, 'windows': windows,
            'mean_error_m': round(float(error), 4),
            'tracked_share': round(float(tracked.mean()), 3)}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--clips', default=','.join(CLIPS),
                    help='clip:body,... (data/motion/CLIP.track or .npz)')
    ap.add_argument('--scene', default='wall=0.3&noise=kinect1')
    ap.add_argument('--jobs', type=int, default=2)
    args = ap.parse_args()
    exe = accuracy.find_eval()
    with tempfile.TemporaryDirectory() as tmp, \
            concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
        rows = list(pool.map(lambda c: run_clip(exe, c, args.scene, tmp),
                             args.clips.split(',')))
    ratios = [w['ratio'] for r in rows for w in r['windows']]
    print(json.dumps({'scene': args.scene, 'commit': accuracy.git_commit(),
                      'clips': rows, 'worst_ratio_off': round(
                          max(abs(r - 1) for r in ratios), 3)}))
    return 0


if __name__ == '__main__':
    sys.exit(main())
