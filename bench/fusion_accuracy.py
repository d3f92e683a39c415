#!/usr/bin/python3
"""Accuracy, latency and bounds of multi-sensor fusion against the truth.

Renders one motion through the virtual Kinect from 2-4 poses around the
dancer (front, behind and to the left, right, behind and to the right:
the views behind see the body hide its own joints), tracks each view with
the depth tracker (tracker_eval --dump), gives each view its own frame
phase, clock drift, stamp error (the clock model's residual) and pipeline
latency, feeds the skeletons to hri_sync.fusion in arrival order on a
simulated clock (plus the fusion's own compute time) and compares with the
rendered truth. Prints one JSON object:

- ``single_view_mean_m``: each view's mean joint error on its tracked
  frames; ``fused_mean_m``: the fused body's, on every fused instant;
- ``best_view_hidden_mean_m`` / ``fused_hidden_mean_m``: on the instants
  and joints the best single view has at confidence < 0.5 (hidden),
  the best view (interpolated to the instant) and the fused body (null,
  and the hidden-joint target null, where the best view hides none);
- ``latency_p95_ms``: publish time minus the newest capture used, beside
  ``slowest_pipeline_p95_ms`` (the slowest view's own latency);
- ``duplicate_people``: person ids beyond the one dancer;
  ``missing_frames``: instants without a person once tracking started;
- ``bound_coverage``: share of fused joints within their 95 % bound;
  ``bound_median_m``: the bounds' median;
- ``unmatched_instants``: per view, the fused instants it was reported
  ``unmatched`` (sharing no person with any view though one's people are
  in the other's sight: hri_sync.fusion.sightlines), which should be none
  with every pose right;
- ``view_oracle_mean_m`` / ``view_oracle_hidden_mean_m``: at each fused
  instant and joint the view nearest the truth (which no fusion can
  know): a ceiling for any weighting of the views;
- ``hidden_by_views_seeing``: the best view's hidden joints by how many
  other views see them (``0``, ``1``, ``2+``: at confidence >= 0.5): each
  group's share, the best view's and the fused error (``1``: and the
  error of the view that sees it);
- ``best_view_alone``: the best view alone through the same fusion (its
  profile, joint filter and posture, no other view): ``mean_m`` and
  ``hidden_mean_m`` (its instants, the joints the best view hides): what
  the fusion's steps give one view, the other views apart;
- ``best_view_instants``: the best view and the fused body on the same
  instants and joints (the fused instants the best view has a skeleton
  at: ``share``): ``single_view_mean_m`` covers a view's tracked frames
  only, ``fused_mean_m`` every fused instant;
- ``labels_from_later``: the fused body as a recording fused afterwards
  gives it, each instant whose sides were in doubt given the labels of
  the next sure one (hri_sync.fusion.relabel; fuse_bag
  --labels-from-later): ``fused_mean_m``, ``fused_hidden_mean_m``,
  ``bound_coverage`` and ``exchanged_instants``;
- ``no_time_alignment``: the same fusion fed each view's arrival time as
  its stamp (a plain subscriber), same figures;
- ``targets``: each target and whether it is met.

``--people 2`` or ``3``: the dancer's first 13 s and one or two walkers
crossing (WALKERS), every view tracked as several users, the fused people
scored against the truth instead (hri_sync_support.fusion_people):
``id_switches``, ``reentries``, ``id_transfers``, ``duplicate_people``,
``duplicate_instants``, ``missing_people``, ``fused_mean_m`` per person,
``view_alone`` (each view's tracker scored alike); docs/fusion.md.

``--lost P``: each view loses a share P of its frames at random (live
trackers on a busy machine skip frames). ``--frozen VIEW:T0,T1``: VIEW
sends its skeleton of T0 s again and again until T1 s, freshly stamped
(as a driver that re-sends its last skeleton); ``frozen`` gives the
fused error and bound coverage over that span (from 0.5 s in, when the
view is named) and the skeletons each view had left out, by reason.

``--pose-error VIEW:DX,DY,DEG``: the fusion is told VIEW's pose moved DX,
DY m and turned DEG degrees (a pose wrong from the start; the renders are
the true poses'); ``pose_error`` says how far its skeletons were off, when
they were first fused with another view's, which views were reported and
the fitted pose's error.

    bench/fusion_accuracy.py --motion data/motion/cmu_60_01_salsa.track \
        --views 3
    bench/fusion_accuracy.py \
        --motion /work/shared/data/mocap/cmu_61_01_salsa.bvh --views 4
    bench/fusion_accuracy.py --motion data/motion/cmu_60_01_salsa.track \
        --views 3 --people 3

Renders are cached in --cache (default /tmp/hri_sync_fusion). Needs the
built workspace sourced (source WS/devel/setup.bash).
"""
import argparse
import concurrent.futures
import dataclasses
import functools
import hashlib
import importlib.util
import json
import math
import os
import subprocess
import sys
import time

import numpy as np
import yaml

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, 'src'))
sys.path.insert(0, os.path.join(ROOT, 'support'))

from hri_sync.dance_off.joints import NUM_JOINTS  # noqa: E402
from hri_sync.dance_off.motion import Motion, load_motion  # noqa: E402
from hri_sync.fusion.align import Sample, Track  # noqa: E402
from hri_sync.fusion.associate import body_distance  # noqa: E402
from hri_sync.fusion.frames import SensorPose, facing  # noqa: E402
from hri_sync.fusion.lag import FilterLag  # noqa: E402
from hri_sync.fusion.pipeline import Fusion, FusionParams  # noqa: E402
from hri_sync.fusion.profile import (  # noqa: E402
    Profile, fit_profile, sides_as_truth, timing_spread)
from hri_sync.fusion.relabel import labels_from_later  # noqa: E402
from hri_sync.fusion.truth import world_motion  # noqa: E402
from hri_sync_support.fusion_people import (  # noqa: E402
    gait_cycle, match, score, walker)

_SPEC = importlib.util.spec_from_file_location(
    'tracker_accuracy', os.path.join(ROOT, 'bench', 'tracker_accuracy.py'))
accuracy = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(accuracy)

FPS = 30            # each view's frame rate (--fps)
PROFILE = os.path.join(ROOT, 'config', 'fusion_depth_tracker.yaml')
HIDDEN = 0.5        # confidence under which a joint is hidden
# name, position (m, the dancer's mean torso at the origin, facing +x),
# frame phase (s), drift, stamp error sigma (s), pipeline latency (s).
VIEWS = [
    ('front', (3.3, 0.4), 0.000, 40e-6, 0.0004, 0.045),
    ('back_left', (-2.3, 2.3), 0.011, -25e-6, 0.0008, 0.070),
    ('right', (0.5, -3.3), 0.023, 10e-6, 0.0006, 0.055),
    ('back_right', (-2.6, -2.0), 0.006, -60e-6, 0.0010, 0.085),
]
JITTER = 0.004      # s, mean of the exponential pipeline jitter
USERS = 4           # users each view's tracker follows (--people 2, 3)
# --people 2, 3: the dancer and one or two walkers, each crossing (start s,
# lane m to the left of the heading, heading deg) a CROSSING m path past
# the dancer: they pass each other half way, then come back in each
# other's lane (hri_sync_support.fusion_people).
WALKERS = [[(1.0, 0.9, 60.0), (8.0, -1.6, 240.0)],
           [(1.3, -1.6, 240.0), (8.3, 0.9, 60.0)]]
CROSSING = 6.0
PEOPLE_SECONDS = 13.0
WALK = os.path.join(ROOT, 'data', 'motion', 'cmu_131_01_walk.track')
TICK = 0.005        # s, the node's poll period


def view_pose(i):
    """The SensorPose of view ``i`` (level, 1 m up, towards the origin)."""
    return facing(VIEWS[i][1][0], VIEWS[i][1][1], 1.0)


def capture_times(i, n):
    """True global capture time of view ``i``'s frames 0..n-1."""
    _, _, phase, drift, _, _ = VIEWS[i]
    return phase + np.arange(n) / FPS * (1 + drift)


@functools.lru_cache(maxsize=None)
def build_id(path):
    """A digest of the executable at ``path`` (read once per run)."""
    with open(path, 'rb') as f:
        return hashlib.sha1(f.read()).hexdigest()


def motion_id(motion):
    """A digest of a motion's times and joint positions (to 1 ns and 1 nm):
    motions that differ at all get renders of their own. A clip's .npz and
    its .track do: the .track's times are rounded to 0.1 ms, which moves
    the sampled joints by up to 0.1 mm, enough to change a view's tracking
    by centimetres."""
    return hashlib.sha1(np.round(motion.times, 9).tobytes()
                        + np.round(motion.positions, 9).tobytes()).hexdigest()


def render(i, motions, cache, scene, eval_path):
    """View ``i``'s tracker dump file (rendered once, then cached for this
    build of tracker_eval and these motions): the first motion is the person
    (tracked alone, ``--dump``); more are the crowd (``crowd_tracks``), every
    user tracked (``--dump-users``)."""
    world = motions[0]
    n = int(world.duration * FPS) - 2
    ident = (world.name, motion_id(world), VIEWS[i], scene, n,
             build_id(eval_path)) + ((FPS,) if FPS != 30 else ())
    if len(motions) > 1:
        ident += (USERS,) + tuple(motion_id(m) for m in motions[1:])
    key = hashlib.sha1(repr(ident).encode()).hexdigest()[:12]
    dump = os.path.join(cache, '%s_%s%s_%s.dump' % (
        world.name, VIEWS[i][0], '_%dp' % len(motions) if len(motions) > 1
        else '', key))
    if os.path.exists(dump):
        return dump
    tau = np.arange(int(n / FPS * 60) + 2) / 60.0
    _, _, phase, drift, _, _ = VIEWS[i]
    t_world = np.clip(phase + tau * (1 + drift), 0, world.duration)
    part = '%s.%d.part' % (dump, os.getpid())  # runs side by side
    tracks = []
    for k, motion in enumerate(motions):
        tracks.append('%s_%d.%d.track' % (dump[:-5], k, os.getpid()))
        Motion(tau, view_pose(i).from_world(motion.positions_at(
            t_world, 'clamp'))).save_track(tracks[-1])
    out = ['--dump', part]
    if len(motions) > 1:
        scene += '&crowd_tracks=' + ','.join(tracks[1:])
        out = ['--users', str(USERS), '--dump-users', part]
    subprocess.run([eval_path, '--track', tracks[0], '--direct', '--scene',
                    scene, '--seconds', '%.3f' % (n / FPS),
                    '--fps', '%g' % FPS] + out,
                   check=True, stdout=subprocess.DEVNULL)
    os.replace(part, dump)
    for track in tracks:
        os.remove(track)
    return dump


def read_dump(path):
    """(tracked (n,), estimated (n, 15, 3), truth (n, 15, 3), conf)."""
    rows = np.array([[float(v) for v in line.split()[:2 + 6 * NUM_JOINTS
                                                    + NUM_JOINTS]]
                     for line in open(path)])
    k = 3 * NUM_JOINTS
    return (rows[:, 1] > 0, rows[:, 2:2 + k].reshape(-1, NUM_JOINTS, 3),
            rows[:, 2 + k:2 + 2 * k].reshape(-1, NUM_JOINTS, 3),
            rows[:, 2 + 2 * k:])


def messages(views, rng):
    """Each view's skeletons as the fusion receives them (``timed``)."""
    return timed([[(n, 1, est[n], conf[n]) for n in np.flatnonzero(tracked)]
                  for tracked, est, _, conf in views], rng)


def timed(views, rng):
    """Skeletons as the fusion receives them, in arrival order: dicts with
    the view, user, arrival time, stamp (true capture + the clock model's
    error), true capture, uncertainty, Skeleton-frame joints and
    confidences. ``views``: per view, [(frame, user, positions,
    confidence)]."""
    out = []
    for i, skeletons in enumerate(views):
        _, _, _, _, sigma, latency = VIEWS[i]
        caught = capture_times(i, 1 + max((s[0] for s in skeletons),
                                          default=0))
        for n, user, positions, confidence in skeletons:
            out.append({
                'view': VIEWS[i][0], 'user': user, 'capture': caught[n],
                'stamp': caught[n] + rng.normal(0, sigma),
                'uncertainty': 2.5 * sigma + 1e-5,
                'arrival': caught[n] + latency + rng.exponential(JITTER),
                'positions': positions, 'confidence': confidence})
    return sorted(out, key=lambda m: m['arrival'])


def faulty(msgs, args):
    """``msgs`` with each view's lost frames left out (``--lost``) and a
    view frozen (``--frozen``: its joints and confidences of the first
    skeleton captured in [T0, T1) repeated until T1)."""
    rng = np.random.default_rng([args.seed, 1])
    msgs = [m for m in msgs if rng.random() >= args.lost]
    if args.frozen:
        view, t0, t1 = args.frozen
        held = None
        for m in sorted(msgs, key=lambda m: m['capture']):
            if m['view'] == view and t0 <= m['capture'] < t1:
                held = held or (m['positions'], m['confidence'])
                m['positions'], m['confidence'] = held
    return msgs


def frozen_figures(spec, frames, fusion, truth):
    """The fused body while a view is frozen (``--frozen``: ``spec``),
    from 0.5 s in (when the fusion names it), and the skeletons each view
    had left out, by reason."""
    _, t0, t1 = spec
    people = [f for f in frames if f.people and t0 + 0.5 <= f.stamp < t1]
    stamps = np.array([f.stamp for f in people])
    err = np.linalg.norm(np.array([f.people[0].body.positions
                                   for f in people]) - truth(stamps),
                         axis=-1)
    bound = np.array([f.people[0].body.bound for f in people])
    ok = np.isfinite(err)
    return {'fused_mean_m': round(float(err[ok].mean()), 4),
            'bound_coverage': round(float((err[ok] <= bound[ok]).mean()), 4),
            'people': sorted({len(f.people) for f in frames
                              if t0 <= f.stamp < t1}),
            'rejected': {v: dict(h.rejected)
                         for v, h in fusion.health.items() if h.rejected}}


def run_fusion(msgs, poses, aligned, profile, inspect=None):
    """Frames of the fusion fed ``msgs`` in arrival order, polled after
    each and every TICK s; stamps are arrival times when not ``aligned``.
    Also {stamp used: true capture} for the latency, and the Fusion.
    ``inspect``: the Fusion's recorder (Fusion.inspect)."""
    sim = {'now': 0.0, 'wall': time.thread_time()}
    fusion = Fusion(poses, FusionParams(),
                    lambda: sim['now'] + time.thread_time() - sim['wall'],
                    {v: profile for v in poses})
    fusion.inspect = inspect
    frames, captured = [], {}
    tick = msgs[0]['arrival']
    for m in msgs + [None]:
        until = m['arrival'] if m else tick + 1.0
        while tick < until:
            sim.update(now=tick, wall=time.thread_time())
            frames += fusion.poll()
            tick += TICK
        if m is None:
            break
        stamp = m['stamp'] if aligned else m['arrival']
        captured[stamp] = m['capture']
        sim.update(now=m['arrival'], wall=time.thread_time())
        fusion.add(m['view'], m['user'], stamp, m['positions'],
                   m['confidence'], m['uncertainty'])
        frames += fusion.poll()
    return frames, captured, fusion


def truth_at(views, poses, t):
    """The rendered truth in world at instants ``t`` (mean of views)."""
    out = []
    for i, (_, _, truth, _) in enumerate(views):
        caught = capture_times(i, len(truth))
        world = poses[i].to_world(truth)
        out.append(Motion(caught, world).positions_at(t, 'clamp'))
    return np.mean(out, axis=0)


def best_view_track(msgs, view, poses, aligned, profile):
    """The best view's Track (as the fusion keeps it: its profile
    applied)."""
    track, lag = Track(keep=1e9), profile.filter_lag()
    pose = poses[[v[0] for v in VIEWS].index(view)]
    for m in msgs:
        if m['view'] == view:
            stamp = m['stamp'] if aligned else m['arrival']
            track.add(Sample(stamp - profile.delay,
                             profile.place(m['positions'], pose, stamp,
                                           lag),
                             m['confidence'], m['uncertainty']))
    return track


def single_view_errors(views, poses, profile, truth):
    """Each view's mean joint error (m) on its tracked frames, through the
    tracker profile (dated, corrected) and as published; NaN for a view
    that never tracked the person."""
    fixed, raw = [], []
    for i, (tracked, est, own_truth, _) in enumerate(views):
        if not tracked.any():
            fixed.append(math.nan)
            raw.append(math.nan)
            continue
        raw.append(np.linalg.norm(est[tracked] - own_truth[tracked],
                                  axis=-1).mean())
        caught = capture_times(i, len(tracked))[tracked]
        lag = profile.filter_lag()
        world = [profile.place(p, poses[i], t, lag)
                 for p, t in zip(est[tracked], caught)]
        fixed.append(np.linalg.norm(np.array(world)
                                    - truth(caught - profile.delay),
                                    axis=-1).mean())
    return fixed, raw


def fitted_profile(views, poses, truth, tracker_filter, exchanged=None,
                   centre=np.nanmean):
    """The tracker profile measured on these views: the delay that fits
    best (10 ms steps; with the tracker's filter, ``tracker_filter``, the
    delay and the cap on its lag that fit best together), then offsets
    (each joint's ``centre`` of its errors), sigmas, the confidence power
    and the arms' growth from behind, and the timing spread of the views
    so corrected (delay_spread); given a list ``exchanged``, each view's
    left and right put the truth's way first
    (hri_sync.fusion.profile.sides_as_truth) and the count of view-frames
    so put appended to it."""
    t = np.arange(math.ceil(FPS), int(len(views[0][0]) - FPS)) / FPS
    conf, ok = [], np.ones(len(t), bool)
    for i, (tracked, _, _, c) in enumerate(views):
        caught = capture_times(i, len(tracked))
        conf.append(c[np.clip(np.searchsorted(caught, t), 0, len(c) - 1)])
        ok &= np.interp(t, caught, tracked.astype(float)) >= 1.0
    caps = [None] if tracker_filter is None else np.arange(0.03, 0.101, 0.01)
    scan = {}
    for delay in np.arange(0.0, 0.101, 0.01):
        for cap in caps:
            params = None if cap is None else dataclasses.replace(
                tracker_filter, max_lag=float(cap))
            est = redated(views, poses, params, delay, t)[:, ok]
            scan[(delay, cap)] = (np.linalg.norm(
                est - truth(t[ok] - delay), axis=-1).mean(), params, est)
    delay, cap = min(scan, key=lambda k: scan[k][0])
    _, params, est = scan[(delay, cap)]
    sensors = [p.translation() for p in poses]
    when = t[ok] - delay
    conf = np.array(conf)[:, ok]
    if exchanged is not None:
        est, conf, n = sides_as_truth(est, truth(when), conf)
        exchanged.append(n)
    profile = fit_profile(est, truth(when), float(delay), float(delay),
                          conf, np.array(sensors), centre)
    profile.filter = params
    fixed = np.array([[profile.correct(e, s) for e in view]
                      for view, s in zip(est, sensors)])
    profile.delay_spread = timing_spread(
        fixed - truth(when), (truth(when + 0.005) - truth(when - 0.005))
        / 0.01)
    return profile


def redated(views, poses, params, delay, t):
    """Each view's joints in world at instants ``t``, each skeleton
    re-dated by the tracker's filter ``params`` (None: not) to ``delay``
    s before its capture."""
    out = []
    for i, (tracked, e, _, _) in enumerate(views):
        caught = capture_times(i, len(tracked))
        e = np.array(e, float)
        if params is not None:
            lag = FilterLag(params, delay)
            for n in np.flatnonzero(tracked):
                e[n] = lag.redate(caught[n], e[n])
        out.append(Motion(caught, poses[i].to_world(e)).positions_at(t))
    return np.array(out)


def mean_m(errors):
    """The mean of ``errors`` (m) to 0.1 mm; None when there are none."""
    return round(float(np.mean(errors)), 4) if len(errors) else None


def figures(frames, captured, truth, best_track):
    """The fused figures of one run (see the module docstring)."""
    people = [f for f in frames if f.people]
    stamps = np.array([f.stamp for f in people])
    fused = np.array([f.people[0].body.positions for f in people])
    bound = np.array([f.people[0].body.bound for f in people])
    err = np.linalg.norm(fused - truth(stamps), axis=-1)
    ok = np.isfinite(err)
    hidden_best, hidden_fused = [], []
    for k, t in enumerate(stamps):
        a = best_track.at(t, 0.04)
        if a is None:
            continue
        for j in np.flatnonzero((a.confidence < HIDDEN)
                                & np.isfinite(a.positions).all(axis=1)
                                & ok[k]):
            hidden_best.append(np.linalg.norm(a.positions[j]
                                              - truth([t])[0][j]))
            hidden_fused.append(err[k, j])
    latency = [f.published - captured.get(p.newest, p.newest)
               for f in people for p in f.people]
    first = people[0].stamp if people else math.inf
    ids = {p.person for f in frames for p in f.people}
    return {
        'fused_mean_m': round(float(err[ok].mean()), 4),
        'best_view_hidden_mean_m': mean_m(hidden_best),
        'fused_hidden_mean_m': mean_m(hidden_fused),
        'hidden_joint_instants': len(hidden_best),
        'latency_p95_ms': round(float(np.percentile(latency, 95)) * 1e3, 1),
        'duplicate_people': max(len(ids) - 1, 0),
        'duplicate_frames': sum(len(f.people) > 1 for f in frames),
        'missing_frames': sum(not f.people for f in frames
                              if f.stamp >= first),
        'bound_coverage': round(float((err[ok] <= bound[ok]).mean()), 4),
        'bound_median_m': round(float(np.median(bound[ok])), 4),
        'fused_frames': len(people),
    }


def alone_figures(msgs, view, pose, profile, truth, track):
    """``view`` alone through the fusion (its ``track`` telling the hidden
    joints): its mean error and on its hidden joints (m)."""
    frames, captured, _ = run_fusion([m for m in msgs if m['view'] == view],
                                     {view: pose}, True, profile)
    alone = figures(frames, captured, truth, track)
    return {'mean_m': alone['fused_mean_m'],
            'hidden_mean_m': alone['fused_hidden_mean_m']}


def declared_poses(error, names, poses):
    """The poses the fusion is given: the views' own, but for ``error``
    (VIEW:DX,DY,DEG)."""
    declared = dict(zip(names, poses))
    if error:
        view, _, moved = error.partition(':')
        dx, dy, deg = (float(v) for v in moved.split(','))
        p = declared[view]
        declared[view] = SensorPose(p.x + dx, p.y + dy, p.z,
                                    p.yaw + math.radians(deg), p.pitch)
    return declared


def pose_figures(view, frames, fusion, true, declared, truth):
    """How the fusion met a view's wrong pose: its skeletons' offset
    (median, along the floor), when they were first fused with another
    view's (s from the first fused instant), the fitted pose's error."""
    people = [f for f in frames if f.people]
    offsets = [body_distance(declared[view].to_world(true.from_world(
        truth([f.stamp])[0])), truth([f.stamp])[0]) for f in people[::30]]
    joined = [f.stamp for f in people for p in f.people
              if view in p.body.views and len(p.body.views) > 1]
    fitted = fusion.fitted.get(view)
    return {
        'view': view, 'offset_m': round(float(np.median(offsets)), 3),
        'joined_after_s': round(joined[0] - people[0].stamp, 2)
        if joined else None,
        'reported': sorted(v for v, h in fusion.health.items()
                           if h.wrong_pose),
        'fitted_error_m': round(math.hypot(fitted[0].x - true.x,
                                           fitted[0].y - true.y), 3)
        if fitted else None,
        'fitted_error_deg': round(math.degrees(abs(math.remainder(
            fitted[0].yaw - true.yaw, 2 * math.pi))), 2) if fitted else None,
    }


def views_at(frames, truth, tracks):
    """Each fused instant with people: (frame, the truth, {view: its
    aligned skeleton there or None}), every view interpolated once."""
    return [(f, truth([f.stamp])[0],
             {n: tr.at(f.stamp, 0.04) for n, tr in tracks.items()})
            for f in frames if f.people]


def oracle(instants, best):
    """The view nearest the truth at each fused instant and joint (mean
    error, and on the best view's hidden joints); ``instants`` from
    views_at."""
    near, hidden = [], []
    for _, true, seen in instants:
        errs = np.array([np.linalg.norm(a.positions - true, axis=1)
                         for a in seen.values() if a is not None])
        if not len(errs):
            continue
        low = np.nanmin(np.where(np.isfinite(errs), errs, np.inf), axis=0)
        ok = np.isfinite(low)
        near.extend(low[ok])
        if seen[best] is not None:
            hid = (seen[best].confidence < HIDDEN) & ok \
                & np.isfinite(seen[best].positions).all(axis=1)
            hidden.extend(low[hid])
    return {'view_oracle_mean_m': round(float(np.mean(near)), 4),
            'view_oracle_hidden_mean_m': mean_m(hidden)}


def paired_with_best(instants, best):
    """The best view and the fused body on the same instants and joints:
    the fused instants the best view has a skeleton at (its share of
    them), each mean error (m) over the joints both have; the single
    view's own mean covers its tracked frames only, where the fused body
    covers every instant; ``instants`` from views_at."""
    pairs, have = [], 0
    for f, true, seen in instants:
        b = seen[best]
        if b is None:
            continue
        have += 1
        e = np.stack([np.linalg.norm(b.positions - true, axis=1),
                      np.linalg.norm(f.people[0].body.positions - true,
                                     axis=1)], axis=1)
        pairs.extend(e[np.isfinite(e).all(axis=1)])
    if not pairs:
        return {'share': 0.0, 'best_view_m': None, 'fused_m': None}
    e = np.array(pairs)
    return {'share': round(have / len(instants), 3),
            'best_view_m': round(float(e[:, 0].mean()), 4),
            'fused_m': round(float(e[:, 1].mean()), 4)}


def hidden_by_sight(instants, best):
    """The best view's hidden joints split by how many other views see
    them (confidence >= HIDDEN: none, one, two or more): per group its
    share of the instants, the best view's and the fused body's mean
    error, and with one the error of the view that sees it; ``instants``
    from views_at."""
    groups = {'0': [], '1': [], '2+': []}   # (best, fused, lone) errors
    for f, true, seen in instants:
        b = seen[best]
        if b is None:
            continue
        fused = np.linalg.norm(f.people[0].body.positions - true, axis=1)
        for j in np.flatnonzero((b.confidence < HIDDEN)
                                & np.isfinite(b.positions).all(axis=1)
                                & np.isfinite(fused)):
            sees = [np.linalg.norm(a.positions[j] - true[j])
                    for n, a in seen.items() if n != best and a is not None
                    and a.confidence[j] >= HIDDEN
                    and np.isfinite(a.positions[j]).all()]
            groups[str(len(sees)) if len(sees) < 2 else '2+'].append(
                (np.linalg.norm(b.positions[j] - true[j]), fused[j],
                 sees[0] if len(sees) == 1 else math.nan))
    total = sum(len(g) for g in groups.values()) or 1
    out = {}
    for name, g in groups.items():
        e = np.array(g).reshape(-1, 3)
        out[name] = {'share': round(len(g) / total, 3),
                     'best_view_m': round(float(e[:, 0].mean()), 4)
                     if len(g) else None,
                     'fused_m': round(float(e[:, 1].mean()), 4)
                     if len(g) else None}
        if name == '1' and len(g):
            out[name]['seeing_view_m'] = round(float(e[:, 2].mean()), 4)
    return out


def targets(out):
    """Each target of the fusion and whether this run meets it (None: the
    best view hides no joint, nothing for the hidden-joint target)."""
    best = out['single_view_mean_m'][out['best_view']]
    limit = out['slowest_pipeline_p95_ms'] + 33 + 5
    hidden = out['best_view_hidden_mean_m']
    return {k: None if v is None else bool(v) for k, v in {
        'fused_20pct_below_best_view': out['fused_mean_m'] <= 0.8 * best,
        'hidden_40pct_below_best_view': None if hidden is None else
            out['fused_hidden_mean_m'] <= 0.6 * hidden,
        'latency_p95_within_%.0f_ms' % limit: out['latency_p95_ms'] <= limit,
        'no_duplicate_people': out['duplicate_people'] == 0,
        'bound_coverage_95pct': out['bound_coverage'] >= 0.95,
    }.items()}


def frozen_spec(text):
    """``--frozen``'s VIEW:T0,T1 as (view, t0, t1)."""
    try:
        view, span = text.split(':')
        t0, t1 = (float(x) for x in span.split(','))
    except ValueError:
        raise argparse.ArgumentTypeError('VIEW:T0,T1, e.g. front:6,9')
    return view, t0, t1


def arguments(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--motion', required=True, help='.bvh, .npz or .track')
    ap.add_argument('--views', type=int, default=3, choices=(2, 3, 4))
    ap.add_argument('--fps', type=int, default=FPS,
                    help="each view's frame rate (the fusion's stays 30 Hz)")
    ap.add_argument('--scene', default='noise=kinect1')
    ap.add_argument('--seed', type=int, default=1)
    ap.add_argument('--cache', default='/tmp/hri_sync_fusion')
    ap.add_argument('--profile', default=PROFILE,
                    help='the tracker profile (YAML; default %(default)s)')
    ap.add_argument('--table', action='store_true',
                    help='print a short table for people instead of JSON')
    ap.add_argument('--people', type=int, default=1, choices=(1, 2, 3),
                    help='2, 3: the dancer and walkers crossing, tracked '
                    'as several users; ids, switches, duplicates, missing')
    ap.add_argument('--pose-error', metavar='VIEW:DX,DY,DEG',
                    help='tell the fusion that VIEW stands DX, DY m away '
                    'and turned DEG degrees (its renders unchanged): a '
                    'pose wrong from the start')
    ap.add_argument('--lost', type=float, default=0.0, metavar='P',
                    help='each view loses this share of its frames at '
                    'random')
    ap.add_argument('--frozen', metavar='VIEW:T0,T1', type=frozen_spec,
                    help='VIEW repeats its skeleton of T0 s until T1 s, '
                    'freshly stamped')
    ap.add_argument('--jobs', '-j', type=int, default=2, choices=(1, 2),
                    help='views rendered at once')
    ap.add_argument('--fit-profile', action='store_true',
                    help='print the tracker profile measured on this '
                    'motion (YAML) instead of the figures')
    return ap.parse_args(argv)


def rendered_views(args, motions):
    """The views' tracker dump files of ``motions`` (the person, then the
    crowd) and the views' poses."""
    eval_path = accuracy.find_eval()
    os.makedirs(args.cache, exist_ok=True)
    with concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
        dumps = list(pool.map(lambda i: render(i, motions, args.cache,
                                               args.scene, eval_path),
                              range(args.views)))
    return dumps, [view_pose(i) for i in range(args.views)]


def people_motions(dancer, count):
    """World Motions of the dancer's first PEOPLE_SECONDS and of
    ``count - 1`` walkers (WALKERS)."""
    t = np.arange(int(PEOPLE_SECONDS * dancer.rate) + 1) / dancer.rate
    out = [Motion(t, dancer.positions_at(t, 'clamp'), name=dancer.name)]
    walk = world_motion(load_motion(WALK))
    cycle = gait_cycle(walk)
    for crossings in WALKERS[:count - 1]:
        out.append(walker(walk, cycle, [(
            start, (-lane * math.sin(math.radians(heading)),
                    lane * math.cos(math.radians(heading))),
            math.radians(heading), CROSSING)
            for start, lane, heading in crossings], PEOPLE_SECONDS))
    return out


def read_users(path):
    """A --dump-users file: per frame, the tracked users [(user,
    positions (15, 3), confidence (15,))], and the people's truth (frames,
    people, 15, 3)."""
    frames, truth = [], []
    for line in open(path):
        v = line.split()
        k, users = 2, []
        for _ in range(int(v[1])):
            if v[k + 1] == '1':
                users.append((int(v[k]), np.array(v[k + 2:k + 47], float)
                              .reshape(NUM_JOINTS, 3),
                              np.array(v[k + 47:k + 62], float)))
            k += 2 + 4 * NUM_JOINTS
        truth.append(np.array(v[k + 1:], float).reshape(int(v[k]),
                                                        NUM_JOINTS, 3))
        frames.append(users)
    return frames, np.array(truth)


def people_truth(views, poses):
    """truth(t) (people, 15, 3) in world (mean of views) and seen(t)
    (people,) whether some view tracks each person, at instant t."""
    world, seen = [], []
    for i, (frames, truth) in enumerate(views):
        world.append((capture_times(i, len(truth)), poses[i].to_world(truth)))
        seen.append(np.zeros(truth.shape[:2], bool))
        for n, users in enumerate(frames):
            pairs = match(np.array([p for _, p, _ in users]), truth[n])
            seen[-1][n, list(pairs.values())] = True

    def truth_at(t):
        return np.mean([[Motion(caught, w[:, k]).positions_at([t], 'clamp')[0]
                         for k in range(w.shape[1])] for caught, w in world],
                       axis=0)

    def seen_at(t):
        out = np.zeros(len(seen[0][0]), bool)
        for (caught, _), s in zip(world, seen):
            n = round((t - caught[0]) * FPS)
            out |= s[n] if 0 <= n < len(s) else False
        return out
    return truth_at, seen_at


def people_main(args, names, profile):
    """--people: ids kept, switches, duplicates and people missing."""
    motions = people_motions(world_motion(load_motion(args.motion)),
                             args.people)
    dumps, poses = rendered_views(args, motions)
    views = [read_users(d) for d in dumps]
    truth, seen = people_truth(views, poses)
    msgs = timed([[(n, u, p, c) for n, users in enumerate(frames)
                   for u, p, c in users] for frames, _ in views],
                 np.random.default_rng(args.seed))
    out = {'motion': os.path.basename(args.motion), 'views': args.views,
           'lost': args.lost,
           'people': args.people, 'seconds': PEOPLE_SECONDS,
           'view_alone': {}}
    for i, name in enumerate(names):
        mine = {}
        for m in msgs:
            if m['view'] == name:
                mine.setdefault(m['capture'], []).append(
                    (m['user'], poses[i].to_world(m['positions'])))
        out['view_alone'][name] = {k: v for k, v in score(
            sorted(mine.items()), truth, seen).items()
            if k in ('id_switches', 'id_transfers', 'reentries',
                     'duplicate_people',
                     'fused_ids')}
    for aligned in (True, False):
        frames, _, fusion = run_fusion(msgs, dict(zip(names, poses)),
                                       aligned, profile)
        result = score([(f.stamp, [(p.person, p.body.positions)
                                   for p in f.people]) for f in frames],
                       truth, seen)
        result['unmatched_instants'] = dict(fusion.sightlines.instants)
        if aligned:
            out.update(result)
        else:
            out['no_time_alignment'] = result
    print(json.dumps(out, indent=1, default=float))


def main():
    global FPS  # every view's frame times follow it
    args = arguments()
    FPS = args.fps
    names = [v[0] for v in VIEWS[:args.views]]
    with open(args.profile) as f:
        profile = Profile.from_dict(yaml.safe_load(f))
    if args.people > 1:
        people_main(args, names, profile)
        return
    dumps, poses = rendered_views(
        args, [world_motion(load_motion(args.motion))])
    views = [read_dump(d) for d in dumps]

    def truth(t):
        return truth_at(views, poses, t)

    if args.fit_profile:
        print(yaml.safe_dump(fitted_profile(views, poses, truth,
                                            profile.filter).to_dict(),
                             default_flow_style=None, sort_keys=False))
        return
    msgs = faulty(messages(views, np.random.default_rng(args.seed)), args)
    fixed, raw = single_view_errors(views, poses, profile, truth)
    if not np.isfinite(fixed).any():
        sys.exit('fusion_accuracy: no view tracked the person')
    best = names[int(np.nanargmin(fixed))]
    out = {'motion': os.path.basename(args.motion), 'views': args.views,
           'lost': args.lost,
           'single_view_mean_m': per_view(names, fixed),
           'single_view_published_mean_m': per_view(names, raw),
           'best_view': best,
           'slowest_pipeline_p95_ms': round(max(np.percentile(
               [m['arrival'] - m['capture'] for m in msgs
                if m['view'] == name], 95)
               for name, err in zip(names, fixed) if np.isfinite(err))
               * 1e3, 1)}
    declared = declared_poses(args.pose_error, names, poses)
    for aligned in (True, False):
        frames, captured, fusion = run_fusion(msgs, declared, aligned,
                                              profile)
        tracks = {n: best_view_track(msgs, n, poses, aligned, profile)
                  for n in (names if aligned else [best])}
        result = figures(frames, captured, truth, tracks[best])
        result['unmatched_instants'] = dict(fusion.sightlines.instants)
        if aligned:
            out.update(result)
            out['labels_from_later'] = afterwards_figures(
                frames, captured, truth, tracks[best])
            out['best_view_alone'] = alone_figures(
                msgs, best, declared[best], profile, truth, tracks[best])
            instants = views_at(frames, truth, tracks)
            out.update(oracle(instants, best))
            out['best_view_instants'] = paired_with_best(instants, best)
            out['hidden_by_views_seeing'] = hidden_by_sight(instants, best)
            if args.frozen:
                out['frozen'] = frozen_figures(args.frozen, frames, fusion,
                                               truth)
            if args.pose_error:
                out['pose_error'] = pose_figures(
                    args.pose_error.split(':')[0], frames, fusion,
                    poses[names.index(args.pose_error.split(':')[0])],
                    declared, truth)
        else:
            out['no_time_alignment'] = result
    out['targets'] = targets(out)
    if args.table:
        print_table(out)
    else:
        print(json.dumps(out, indent=1, default=float))


def afterwards_figures(frames, captured, truth, best_track):
    """The fused figures of ``frames`` with the sides in doubt put right
    from later instants, as a recording fused afterwards can
    (hri_sync.fusion.relabel): ``fused_mean_m``, ``fused_hidden_mean_m``,
    ``bound_coverage`` and ``exchanged_instants``."""
    relabelled, exchanged = labels_from_later(frames)
    result = figures(relabelled, captured, truth, best_track)
    return {'fused_mean_m': result['fused_mean_m'],
            'fused_hidden_mean_m': result['fused_hidden_mean_m'],
            'bound_coverage': result['bound_coverage'],
            'exchanged_instants': exchanged}


def per_view(names, values):
    """{view: value in m, 4 places}; None for a view that tracked no
    one."""
    return {n: round(float(v), 4) if np.isfinite(v) else None
            for n, v in zip(names, values)}


def metres(value):
    """A figure in m for the table; '-' for None (no hidden joint)."""
    return '-' if value is None else '%.3f' % value


def print_table(out):
    """The demo's view of the figures."""
    plain = out['no_time_alignment']
    print('%-24s %10s %16s' % ('mean joint error (m)', 'all',
                                'best view hides'))
    for view, err in out['single_view_mean_m'].items():
        if err is None:
            print('%-24s %10s' % (view, 'no one'))
            continue
        print('%-24s %10.3f %16s' % (view, err, metres(out[
            'best_view_hidden_mean_m']) if view == out['best_view'] else ''))
    print('%-24s %10.3f %16s' % ('fused', out['fused_mean_m'],
                                 metres(out['fused_hidden_mean_m'])))
    print('%-24s %10.3f %16s' % ('fused, arrival stamps',
                                 plain['fused_mean_m'],
                                 metres(plain['fused_hidden_mean_m'])))
    print('latency p95 %.0f ms (slowest view\'s pipeline %.0f ms); '
          '%d duplicate people; %.1f %% of truth within the 95 %% bounds'
          % (out['latency_p95_ms'], out['slowest_pipeline_p95_ms'],
             out['duplicate_people'], 100 * out['bound_coverage']))


if __name__ == '__main__':
    main()
