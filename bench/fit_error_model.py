#!/usr/bin/python3
"""Fit the fusion's learned error model on views of a motion with its truth.

Runs bench/fusion_accuracy.py's fusion (its renders and its tracker
profile, without an error model) on MOTION with 3 and 4 views and the
renderer's noise seeds 1..N, the motion turned about the vertical by
each of --turns (the same sensors see it from other sides) and, with
--mirrored, mirrored left to right too, and on each --also motion as it
is (real recordings of people facing the front sensor); records at every
fused instant each view's joints as the model takes them
(hri_sync.fusion.errors.inputs: where the joint lies on the fused body
and its confidence) and their squared error against the rendered truth,
and fits a Poisson-loss boosted tree ensemble on them (scikit-learn's
HistGradientBoostingRegressor, seeded). Writes the profile with the
model as its ``errors`` (--out; the profile's other lines unchanged) and
prints JSON: the rows, and per joint kind the measured and the model's
rms error.

    bench/fit_error_model.py --motion data/motion/cmu_60_01_salsa.npz \\
        --turns 0 90 180 270 --also data/motion/real/precog_Seq*.npz \\
        --jobs 2 --out config/fusion_depth_tracker.yaml

Needs the built workspace sourced and scikit-learn (make setup).
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
from hri_sync.dance_off.frames import rotation  # noqa: E402
from hri_sync.fusion.arms import turned as sides_exchanged  # noqa: E402
from hri_sync.fusion.errors import (  # noqa: E402
    INPUTS, ErrorModel, Tree, inputs)
from hri_sync.fusion.facing import back_views  # noqa: E402
from hri_sync.fusion.fuse import LEAST_CONFIDENCE, own_sigma  # noqa: E402
from hri_sync.fusion.profile import Profile  # noqa: E402
from hri_sync.fusion.sightlines import distance  # noqa: E402

KINDS = ('trunk', 'shoulders', 'elbows', 'hands', 'knees', 'feet')
TREES = 200         # boosting steps
LEAVES = 31         # each tree's leaves at most
LEAST = 200         # rows a leaf holds at least
KNOWN = (0.5, 99.5)  # percentiles of the distances the model knows


def recorder(rows, poses, truth, profile):
    """A Fusion.inspect that appends each view's inputs, its distance from
    the person and its squared errors (the joints it can give) to
    ``rows``, as the fusion takes them with ``profile`` (its sigma before
    the range's growth)."""
    def inspect(t, person, views, body):
        true = truth(np.array([t]))[0]
        backs = back_views(body.positions, [poses[o.view].translation()
                                            for o in views])
        for o, back in zip(views, backs):
            sigma = own_sigma(profile.sigma, o.confidence, o.power)
            if o.scale is not None:
                sigma = sigma * o.scale
            sensor = poses[o.view].translation()
            x = inputs(o.positions, o.confidence, sigma, body.positions,
                       sensor, back)
            err2 = ((o.positions - true) ** 2).sum(axis=1)
            ok = np.isfinite(err2) & (o.confidence >= LEAST_CONFIDENCE)
            far = np.full(ok.sum(), distance(body.positions, sensor))
            rows.append(np.column_stack([x[ok], far, err2[ok]]))
    return inspect


def turned(motion, degrees, mirrored=False):
    """A world Motion turned ``degrees`` about the vertical through the
    origin (the dancer's mean torso), after mirroring it left to right
    (world y negated, each left joint swapped with its right one) when
    ``mirrored``; named for both."""
    p = motion.positions
    name = motion.name
    if mirrored:
        p = np.moveaxis(sides_exchanged(np.moveaxis(p, 1, 0)), 0, 1) \
            * np.array([1.0, -1.0, 1.0])
        name += '_mirrored'
    if degrees % 360:
        p = p @ rotation(np.radians(degrees)).T
        name += '_turn%g' % degrees
    return fa.Motion(motion.times, p, name=name) if name != motion.name \
        else motion


def record(motion, world, views, seed, profile, cache, turn=0.0,
           mirrored=False, jobs=1):
    """(rows, inputs + 2) of one run (recorder's): ``views`` views, noise
    ``seed``, the motion at ``motion`` (``world``: it in world, loaded
    once for every run) turned ``turn`` degrees and ``mirrored``
    (``turned``), its views rendered ``jobs`` at once."""
    scene = 'noise=kinect1' if seed == 1 else 'noise=kinect1&seed=%d' % seed
    args = fa.arguments(['--motion', motion, '--views', str(views),
                         '--scene', scene, '--cache', cache,
                         '--jobs', str(jobs)])
    names = [v[0] for v in fa.VIEWS[:views]]
    dumps, poses = fa.rendered_views(args, [turned(world, turn, mirrored)])
    rendered = [fa.read_dump(d) for d in dumps]
    msgs = fa.messages(rendered, np.random.default_rng(args.seed))
    rows = []
    fa.run_fusion(msgs, fa.declared_poses(None, names, poses), True,
                  profile, recorder(rows, dict(zip(names, poses)),
                                    lambda t: fa.truth_at(rendered, poses,
                                                          t), profile))
    return np.concatenate(rows)


def plan(motion, also, views, seeds, turns, mirrored):
    """The runs recorded, (motion, views, seed, turn, mirrored): ``motion``
    turned by each of ``turns`` (and mirrored too, when ``mirrored``),
    each of ``also`` as it is; the most views first (their renders serve
    the fewer), noise seeds 1..``seeds``."""
    return [(m, v, s, turn, mirror)
            for m in [motion] + list(also)
            for mirror in ([False, True] if mirrored and m == motion
                           else [False])
            for turn in (turns if m == motion else [0.0])
            for v in sorted(views, reverse=True)
            for s in range(1, seeds + 1)]


def exported(model, distances):
    """An ErrorModel of a fitted HistGradientBoostingRegressor that knows
    views ``distances`` (near, far) m from the person."""
    trees = []
    for (predictor,) in model._predictors:
        n = predictor.nodes
        trees.append(Tree(np.where(n['is_leaf'], -1,
                                   n['feature_idx']).astype(int),
                          n['num_threshold'].astype(float),
                          n['left'].astype(int), n['right'].astype(int),
                          n['value'].astype(float),
                          n['missing_go_to_left'].astype(bool)))
    return ErrorModel(float(np.ravel(model._baseline_prediction)[0]), trees,
                      distances)


def fit(rows, seed=0):
    """An ErrorModel of rows (inputs, distance, squared error), and the
    fitted scikit-learn model."""
    from sklearn.ensemble import HistGradientBoostingRegressor
    model = HistGradientBoostingRegressor(
        loss='poisson', max_iter=TREES, max_leaf_nodes=LEAVES,
        min_samples_leaf=LEAST, early_stopping=False, random_state=seed)
    model.fit(rows[:, :-2], rows[:, -1])
    far = rows[np.isfinite(rows[:, -2]), -2]
    return exported(model, tuple(np.percentile(far, KNOWN))), model


def summary(model, rows):
    """Per joint kind: rows, measured and modelled rms error (m)."""
    predicted = model.predict(rows[:, :-2])
    kind = rows[:, INPUTS.index('kind')]
    return {name: {'rows': int((kind == k).sum()),
                   'rms_m': round(float(np.sqrt(rows[kind == k, -1].mean())),
                                  4),
                   'model_rms_m': round(float(np.sqrt(
                       predicted[kind == k].mean())), 4)}
            for k, name in enumerate(KINDS) if (kind == k).any()}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--motion', required=True, help='.bvh, .npz or .track')
    ap.add_argument('--also', nargs='+', default=[], metavar='MOTION',
                    help='more motions fitted on with it, each as it is '
                    '(not turned nor mirrored), with the same views and '
                    'seeds')
    ap.add_argument('--views', type=int, nargs='+', default=[3, 4],
                    choices=(2, 3, 4))
    ap.add_argument('--seeds', type=int, default=5,
                    help='noise seeds 1..N (default %(default)s)')
    ap.add_argument('--fps', type=int, default=fa.FPS,
                    help="each view's frame rate (default %(default)s; "
                    'the profile is to be measured at it)')
    ap.add_argument('--turns', type=float, nargs='+', default=[0.0],
                    metavar='DEG', help='the motion also turned by these '
                    'degrees about the vertical (default: as it is)')
    ap.add_argument('--mirrored', action='store_true',
                    help='the motion also mirrored left to right (each turn)')
    ap.add_argument('--profile', default=fa.PROFILE,
                    help='the tracker profile (YAML; default %(default)s)')
    ap.add_argument('--cache', default='/tmp/hri_sync_fusion')
    ap.add_argument('--jobs', type=int, default=1,
                    help='views rendered at once (default %(default)s)')
    ap.add_argument('--out', help='write the profile with the model here')
    args = ap.parse_args()
    fa.FPS = args.fps   # every view's frame times follow it
    with open(args.profile) as f:
        text = f.read()
    values = yaml.safe_load(text)
    values.pop('errors', None)      # fitted again
    base = Profile.from_dict(values)
    worlds = {}
    rows = []
    for motion, views, seed, turn, mirrored in plan(
            args.motion, args.also, args.views, args.seeds, args.turns,
            args.mirrored):
        if motion not in worlds:
            worlds[motion] = fa.world_motion(fa.load_motion(motion))
        rows.append(record(motion, worlds[motion], views, seed, base,
                           args.cache, turn, mirrored, args.jobs))
    rows = np.concatenate(rows)
    model, fitted = fit(rows)
    check = model.predict(rows[:, :-2])
    if not np.allclose(check, fitted.predict(rows[:, :-2]), rtol=1e-6):
        sys.exit('fit_error_model: the exported trees do not reproduce '
                 'the fitted model')
    if args.out:
        command = ' '.join(['bench/fit_error_model.py'] + sys.argv[1:])
        with open(args.out, 'w') as f:
            f.write(with_block(text, 'errors', model.to_dict(), [
                "The learned error model (hri_sync.fusion.errors: a view's",
                'joint error from where it lies), fitted with',
                '  ' + command]))
    print(json.dumps({'motion': os.path.basename(args.motion),
                      'also': [os.path.basename(m) for m in args.also],
                      'views': args.views, 'seeds': args.seeds,
                      'fps': args.fps,
                      'turns_deg': args.turns, 'mirrored': args.mirrored,
                      'rows': len(rows), 'trees': len(model.trees),
                      'distances_m': model.distances,
                      'kinds': summary(model, rows),
                      'written': args.out}, indent=1))


if __name__ == '__main__':
    main()
