#!/usr/bin/python3
"""A still person through the depth tracker, at 1.5-4 m, before walls.

Holds a motion's first pose still for --seconds (default 20), its torso
moved to each distance (and, with --centre, to the optical axis), renders it
in-process with Kinect v1 noise, no wall or a wall --walls m behind the
back, tracks it with the single-user tracker and prints one JSON object:
per row (distance, wall) the tracked share; after the first tracked second
the frame-to-frame step p95 over every joint and the worst joint's p95; the
expressiveness over the run and its largest 2 s window (the project's
expressiveness, joints below confidence 0.5 left out, as the DPM does);
head-to-foot (head joint to the feet joints' midpoint, median over the
last 5 s, once the bone lengths are known) against the rendered truth's;
the torso's largest error. --seeds renders each row with each scene seed
(the Kinect noise's; a row per seed); --eval runs another tracker_eval.

    bench/tracker_still.py                        # the table in docs/tracker.md
    bench/tracker_still.py --distances 2,3 --walls none,0.1 --centre
    bench/tracker_still.py --distances 2.5,3,3.5,4 --walls 0.1 --seconds 12 --seeds 1,2,3,4,5,6

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
    'tracker_accuracy', os.path.join(ROOT, 'bench', 'tracker_accuracy.py'))
accuracy = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(accuracy)

RATE = 30.0
HEAD, TORSO, L_FOOT, R_FOOT = 0, 2, 13, 14


def still_at(track, distance, centre, seconds, path):
    """A .track of the motion's first pose held still, torso at distance."""
    with open(track) as f:
        first = next(line for line in f
                     if line.strip() and not line.startswith('#'))
    pose = np.array(first.split()[1:], dtype=float).reshape(15, 3)
    pose[:, 2] += distance - pose[TORSO, 2]
    if centre:
        pose[:, 0] -= pose[TORSO, 0]
    with open(path, 'w') as f:
        for t in (0.0, seconds):
            f.write('%g %s\n' % (t, ' '.join('%.4f' % v
                                              for v in pose.ravel())))


def head_to_foot(joints):
    feet = (joints[:, L_FOOT] + joints[:, R_FOOT]) / 2
    return np.linalg.norm(joints[:, HEAD] - feet, axis=1)


def read_dump(path):
    """tracker_eval --dump columns: the frames' times (s), whether each was
    tracked, and the estimated joints, true joints and confidences."""
    d = np.loadtxt(path, usecols=range(0, 107), ndmin=2)
    return (d[:, 0] / RATE, d[:, 1] == 1, d[:, 2:47].reshape(-1, 15, 3),
            d[:, 47:92].reshape(-1, 15, 3), d[:, 92:107])


def figures(dump):
    """One row's figures from a tracker_eval --dump."""
    times, tracked, est_all, truth_all, conf_all = read_dump(dump)
    row = {'tracked_share': round(float(tracked.mean()), 3)}
    if not tracked.any():
        return row
    first = int(np.argmax(tracked))
    keep = tracked & (np.arange(len(times)) >= first + int(RATE))
    stamps, est, truth, conf = (times[keep], est_all[keep], truth_all[keep],
                                conf_all[keep])
    steps = np.linalg.norm(np.diff(est, axis=0), axis=2)
    windows = [expressiveness(stamps[k:k + 60], est[k:k + 60],
                              conf[k:k + 60]).value
               for k in range(0, len(stamps) - 59, 60)]
    last = slice(-int(5 * RATE), None)
    ratio = (np.median(head_to_foot(est[last]))
             / np.median(head_to_foot(truth[last])) - 1)
    row.update(
        step_p95_mm=round(1000 * float(np.percentile(steps, 95)), 1),
        worst_joint_step_p95_mm=round(
            1000 * float(np.percentile(steps, 95, axis=0).max()), 1),
        expressiveness=round(expressiveness(stamps, est, conf).value, 4),
        worst_2s_window=round(max(windows), 3) if windows else None,
        head_to_foot_vs_truth=round(float(ratio), 3),
        torso_error_max_m=round(float(np.max(np.linalg.norm(
            est[:, TORSO] - truth[:, TORSO], axis=1))), 3))
    return row


def run_row(exe, track, distance, wall, seed, args, tmp):
    name = '%g_%s_%s' % (distance, wall, seed)
    still = os.path.join(tmp, name + '.track')
    still_at(track, distance, args.centre, args.seconds, still)
    scene = 'noise=kinect1' if wall == 'none' else \
        'wall=%s&noise=kinect1' % wall
    if seed is not None:
        scene += '&seed=%d' % seed
    dump = os.path.join(tmp, name + '.dump')
    subprocess.run([exe, '--track', still, '--direct', '--scene', scene,
                    '--dump', dump], check=True, capture_output=True)
    row = dict(distance_m=distance, wall_m=wall)
    if seed is not None:
        row['seed'] = seed
    return dict(row, **figures(dump))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--motion', default=os.path.join(
        ROOT, 'data', 'motion', 'cmu_60_01_salsa.track'))
    ap.add_argument('--distances', default='1.5,2,2.5,3,3.5,4')
    ap.add_argument('--walls', default='none,0.1,0.3,0.5')
    ap.add_argument('--seconds', type=float, default=20.0)
    ap.add_argument('--centre', action='store_true',
                    help='the torso on the optical axis')
    ap.add_argument('--seeds', default='',
                    help='scene seeds, comma-separated (default: the '
                    "scene's own)")
    ap.add_argument('--eval', default='',
                    help='a tracker_eval to run (default: the built one)')
    ap.add_argument('--jobs', type=int, default=2)
    args = ap.parse_args()
    exe = args.eval or accuracy.find_eval()
    seeds = [int(s) for s in args.seeds.split(',')] if args.seeds else [None]
    cells = [(float(z), w, s) for z in args.distances.split(',')
             for w in args.walls.split(',') for s in seeds]
    with tempfile.TemporaryDirectory() as tmp, \
            concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
        rows = list(pool.map(lambda c: run_row(exe, args.motion, *c, args,
                                               tmp), cells))
    print(json.dumps({'motion': os.path.basename(args.motion),
                      'seconds': args.seconds, 'centre': args.centre,
                      'commit': accuracy.git_commit(), 'rows': rows}))
    return 0


if __name__ == '__main__':
    sys.exit(main())
