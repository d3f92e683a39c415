#!/usr/bin/python3
"""The fusion bench over several draws of the sensors' noise.

One run of bench/fusion_accuracy.py tracks each view once, through one
draw of the Kinect v1 noise. The depth tracker's choices frame by frame
(which tip is a hand, which arm is left) hang on that draw, and a clip's
figures with them: "below the best view" moves by up to 19 points from
one draw to the next. This runs fusion_accuracy.py with the scene's noise
seeds 1 to ``--seeds`` (seed 1 is its default scene) and prints one JSON
object:

- ``runs``: per seed, the figures the targets are stated on: the best
  single view and the fused body (m, and how far below the best view in
  %), the same on the best view's hidden joints, the latency beyond the
  slowest view's pipeline (ms), duplicate people, the bound coverage and
  the bounds' median (m); and ``below_best_same_instants_pct``, the
  fused body below the best view on the instants and joints both have
  (fusion_accuracy.py's ``best_view_instants``: the best view's own mean
  covers its tracked frames only, the fused body's every instant), with
  ``best_view_instant_share``, the share of the fused instants the best
  view has a skeleton at; and ``below_best_alone_pct`` /
  ``hidden_below_best_alone_pct``, the fused body below the best view
  alone through the same fusion (``best_view_alone``: its profile, filter
  and posture); ``nearest_view_below_best_pct`` /
  ``nearest_view_hidden_below_best_pct``, the same for the view nearest
  the truth at each instant and joint (``view_oracle_mean_m``: which no
  fusion can know; where it is short of a target, no choice among the
  views meets it); ``afterwards_below_best_pct`` /
  ``afterwards_hidden_below_best_pct`` and ``afterwards_bound_coverage``,
  the fused body as a recording fused afterwards with the sides in doubt
  put right from later instants gives it (fuse_bag --labels-from-later;
  fusion_accuracy.py's ``labels_from_later``);
- ``summary``: each figure's median, least and greatest over the seeds
  that have it, and in how many (``of``): the hidden-joint figures are
  null in a draw whose best view hides no joint;
- ``targets_met``: per target, in how many of the seeds it is met (of
  the seeds it applies to: ``targets_applied``).

    bench/fusion_noise.py --motion data/motion/cmu_61_01_salsa.track \
        --views 4 --seeds 5

Other arguments go to fusion_accuracy.py as they are (``--profile``,
``--cache``, ``--lost``, ...; not ``--people``, ``--fit-profile`` nor
``--table``, which print other figures). Needs the built workspace
sourced.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BENCH = os.path.join(ROOT, 'bench', 'fusion_accuracy.py')
SCENE = 'noise=kinect1'
OTHER_OUTPUTS = ('--people', '--fit-profile', '--table')


def scene_for(scene, seed):
    """The scene with the renderer's noise seed (1: the scene as given)."""
    return scene if seed == 1 else '%s&seed=%d' % (scene, seed)


def below(value, reference):
    """How far ``value`` is below ``reference`` (%); None without both."""
    if value is None or reference is None:
        return None
    return round(100 * (1 - value / reference), 1)


def figures(out):
    """The target figures of one fusion_accuracy.py JSON result."""
    best = out['single_view_mean_m'][out['best_view']]
    hidden = out['best_view_hidden_mean_m']
    paired = out['best_view_instants']
    alone = out['best_view_alone']
    later = out['labels_from_later']
    return {
        'best_view_m': best,
        'fused_m': out['fused_mean_m'],
        'below_best_pct': below(out['fused_mean_m'], best),
        'best_view_hidden_m': hidden,
        'fused_hidden_m': out['fused_hidden_mean_m'],
        'hidden_below_best_pct': below(out['fused_hidden_mean_m'], hidden),
        'latency_beyond_slowest_ms': round(
            out['latency_p95_ms'] - out['slowest_pipeline_p95_ms'], 1),
        'duplicate_people': out['duplicate_people'],
        'bound_coverage': out['bound_coverage'],
        'bound_median_m': out['bound_median_m'],
        'below_best_same_instants_pct': below(paired['fused_m'],
                                              paired['best_view_m']),
        'best_view_instant_share': paired['share'],
        'below_best_alone_pct': below(out['fused_mean_m'], alone['mean_m']),
        'hidden_below_best_alone_pct': below(out['fused_hidden_mean_m'],
                                             alone['hidden_mean_m']),
        'nearest_view_below_best_pct': below(out['view_oracle_mean_m'], best),
        'nearest_view_hidden_below_best_pct': below(
            out['view_oracle_hidden_mean_m'], hidden),
        'afterwards_below_best_pct': below(later['fused_mean_m'], best),
        'afterwards_hidden_below_best_pct': below(
            later['fused_hidden_mean_m'], hidden),
        'afterwards_bound_coverage': later['bound_coverage'],
    }


def verdicts(out):
    """fusion_accuracy.py's own verdict on each target, the latency's under
    one name for every run (its limit is each run's slowest view + 38 ms)."""
    return {('latency_p95_within_38_ms_of_slowest_view'
             if name.startswith('latency_p95_within_') else name): met
            for name, met in out['targets'].items()}


def targets_met(runs):
    """Per target, how many runs meet it, and how many it applies to."""
    names = runs[0]['targets']
    return ({name: sum(1 for r in runs if r['targets'][name])
             for name in names},
            {name: sum(1 for r in runs if r['targets'][name] is not None)
             for name in names})


def summary(runs):
    """Each figure's median, least and greatest over the ``runs`` that
    have it (None where none has), and in how many."""
    out = {}
    for key in runs[0]:
        if key in ('seed', 'targets'):
            continue
        values = [r[key] for r in runs if r[key] is not None]
        out[key] = {'median': round(statistics.median(values), 4)
                    if values else None,
                    'min': min(values, default=None),
                    'max': max(values, default=None), 'of': len(values)}
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--seeds', type=int, default=5,
                    help='noise seeds 1..N (default %(default)s)')
    ap.add_argument('--scene', default=SCENE)
    args, rest = ap.parse_known_args()
    if args.seeds < 1:
        ap.error('--seeds must be 1 or more')
    other = [a for a in rest if a.split('=')[0] in OTHER_OUTPUTS]
    if other:
        ap.error('%s prints other figures; run fusion_accuracy.py for it'
                 % other[0])
    runs = []
    for seed in range(1, args.seeds + 1):
        proc = subprocess.run(
            [sys.executable, BENCH, '--scene', scene_for(args.scene, seed)]
            + rest, capture_output=True, text=True)
        if proc.returncode != 0:
            sys.exit('fusion_noise: fusion_accuracy.py failed at seed %d: %s'
                     % (seed, proc.stderr.strip()[-2000:]))
        out = json.loads(proc.stdout)
        runs.append(dict(seed=seed, targets=verdicts(out), **figures(out)))
    met, applied = targets_met(runs)
    print(json.dumps({'scene': args.scene, 'arguments': rest, 'runs': runs,
                      'summary': summary(runs), 'targets_met': met,
                      'targets_applied': applied, 'seeds': args.seeds},
                     indent=1))


if __name__ == '__main__':
    main()
