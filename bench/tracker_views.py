#!/usr/bin/python3
"""The depth tracker on dancers seen from four sides, three bodies each.

Each clip of data/motion is rendered through the virtual Kinect from the
four poses of bench/fusion_accuracy.py (in front; behind and to the left;
to the right; behind and to the right: 3.3 m away, 1 m up), with Kinect v1
noise and three bodies (average; tall_slim 0.3 m before a wall;
short_broad), and tracked by tracker_eval (its first 20 s). A user first
seen from behind or side-on is where the bone lengths' calibration is
hardest: the head must be found among a shoulder, a chest and an arm, and
the body may be cut in two at a depth step. Prints one JSON object: per run
the calibrated height (the tracker's model) against the rendered body's,
the mean joint error, the hands' p95 error, the tracked share and the
share of tracked frames facing the wrong way round (left and right
exchanged); and a summary: runs whose height is more than 8 % and 15 %
off, the mean error overall, per view and per body, the mean share facing
wrong and the runs facing wrong in more than 5 % of their frames. ``--baseline EVAL`` runs a second
tracker_eval on the same renders beside it (``baseline`` and ``paired``:
runs better or worse by more than 5 mm).

    bench/tracker_views.py
    bench/tracker_views.py --baseline OLD/tracker_eval --clips cmu_60_01_salsa

Needs the built workspace sourced (source WS/devel/setup.bash).
"""
import argparse
import concurrent.futures
import importlib.util
import itertools
import json
import os
import subprocess
import sys
import tempfile

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, 'src'))
from hri_sync.dance_off.motion import Motion, load_motion  # noqa: E402
from hri_sync.fusion.truth import world_motion  # noqa: E402

_spec = importlib.util.spec_from_file_location(
    'fusion_accuracy', os.path.join(ROOT, 'bench', 'fusion_accuracy.py'))
fusion = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(fusion)

CLIPS = ('cmu_60_01_salsa', 'cmu_61_01_salsa', 'cmu_60_04_salsa',
         'cmu_60_07_salsa', 'cmu_61_04_salsa', 'cmu_61_07_salsa',
         'cmu_131_01_walk')
SCENES = ('noise=kinect1', 'noise=kinect1&wall=0.3&body=tall_slim',
          'noise=kinect1&body=short_broad')
SECONDS = 20.0
KEYS = ('height_m', 'body_height_m', 'mean_error_m', 'hands_p95_error_m',
        'tracked_share', 'facing_wrong_share')


def tracks(clips, folder):
    """(clip, view, .track path, seconds) of every clip from every view."""
    out = []
    for clip in clips:
        world = world_motion(load_motion(os.path.join(
            ROOT, 'data', 'motion', clip + '.npz')))
        n = int(world.duration * fusion.FPS) - 2
        tau = np.arange(int(n / fusion.FPS * 60) + 2) / 60.0
        t = np.clip(tau, 0, world.duration)
        for i, view in enumerate(fusion.VIEWS):
            path = os.path.join(folder, '%s_%s.track' % (clip, view[0]))
            Motion(tau, fusion.view_pose(i).from_world(
                world.positions_at(t, 'clamp'))).save_track(path)
            out.append((clip, view[0], path, min(n / fusion.FPS, SECONDS)))
    return out


def track(eval_path, path, seconds, scene):
    """tracker_eval's figures (KEYS) for one render."""
    r = subprocess.run([eval_path, '--track', path, '--direct', '--scene',
                        scene, '--seconds', '%.2f' % seconds],
                       capture_output=True, text=True, check=True)
    d = json.loads(r.stdout)
    return {k: d[k] for k in KEYS}


def summary(runs):
    """Height misses and mean errors over the runs."""
    off = [abs(r['height_m'] / r['body_height_m'] - 1) for r in runs]

    def mean_by(key):
        groups = {}
        for r in runs:
            groups.setdefault(r[key], []).append(r['mean_error_m'])
        return {k: round(float(np.mean(v)), 4) for k, v in groups.items()}
    return {'runs': len(runs),
            'height_off_8pct': sum(o > 0.08 for o in off),
            'height_off_15pct': sum(o > 0.15 for o in off),
            'mean_error_m': round(float(np.mean(
                [r['mean_error_m'] for r in runs])), 4),
            'facing_wrong_share': round(float(np.mean(
                [r['facing_wrong_share'] for r in runs])), 4),
            'facing_wrong_over_5pct': sum(r['facing_wrong_share'] > 0.05
                                          for r in runs),
            'mean_error_by_view_m': mean_by('view'),
            'mean_error_by_scene_m': mean_by('scene')}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--clips', nargs='+', default=list(CLIPS))
    ap.add_argument('--baseline', help='a second tracker_eval to compare')
    ap.add_argument('--jobs', '-j', type=int, default=2)
    args = ap.parse_args()
    builds = {'tracker': fusion.accuracy.find_eval()}
    if args.baseline:
        builds['baseline'] = args.baseline
    with tempfile.TemporaryDirectory() as folder:
        cases = [(c, v, p, s, scene) for (c, v, p, s), scene
                 in itertools.product(tracks(args.clips, folder), SCENES)]
        jobs = list(itertools.product(builds.items(), cases))
        with concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
            done = list(pool.map(lambda j: track(j[0][1], *j[1][2:]), jobs))
    runs = {name: [] for name in builds}
    for ((name, _), (clip, view, _, _, scene)), figures in zip(jobs, done):
        runs[name].append(dict(clip=clip, view=view, scene=scene, **figures))
    out = {'tracker': {'summary': summary(runs['tracker']),
                       'runs': runs['tracker']}}
    if args.baseline:
        out['baseline'] = {'summary': summary(runs['baseline']),
                           'runs': runs['baseline']}
        diff = [a['mean_error_m'] - b['mean_error_m']
                for a, b in zip(runs['tracker'], runs['baseline'])]
        out['paired'] = {'better_by_5mm': sum(d < -0.005 for d in diff),
                         'worse_by_5mm': sum(d > 0.005 for d in diff)}
    print(json.dumps(out, indent=1))


if __name__ == '__main__':
    main()
