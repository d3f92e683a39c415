"""Calibration checked, not trusted: residuals between views, a wrong
sensor pose, and a pose refined from a person seen by two views.

The residual of a pair of views is the mean distance (m) between their
joints of the same person at the same instant (joints both see with
confidence >= ``min_confidence``), averaged with a time constant of
``tau`` s. A view whose residuals with every other view are over
``threshold`` while the other views agree with each other (three or more
views) has a wrong pose; with two views a high residual names the pair
only (either pose may be wrong). ``shared_points`` and ``refine_pose``
refine a view's pose from a person the other views see
(scripts/fusion_refine_pose.py). ``PoseFit`` does it while the fusion
runs, for a view whose pose is wrong by more than the association gate
(its skeletons join none of the people the others see) as well.
"""

from __future__ import annotations

import collections
import math
from dataclasses import dataclass
from typing import Deque, Dict, List, Optional, Tuple

import numpy as np

from hri_sync.dance_off.frames import SENSOR, rotation
from hri_sync.fusion.align import Sample, Track
from hri_sync.fusion.frames import MIRROR, SensorPose

Pair = Tuple[str, str]


@dataclass
class Residual:
    """A pair's running residual (m) and its count of instants."""

    mean: float = 0.0
    count: int = 0
    last: float = -math.inf


class Residuals:
    """Running residuals of every pair of views."""

    def __init__(self, tau: float = 5.0, threshold: float = 0.2,
                 min_confidence: float = 0.5, min_count: int = 30) -> None:
        self.tau = tau
        self.threshold = threshold
        self.min_confidence = min_confidence
        self.min_count = min_count
        self.pairs: Dict[Pair, Residual] = {}

    def add(self, t: float, bodies: Dict[str, Tuple[np.ndarray, np.ndarray]]
            ) -> None:
        """One person's views at instant ``t``: view -> (positions (15, 3)
        world, confidence (15,))."""
        views = sorted(bodies)
        for i, a in enumerate(views):
            for b in views[i + 1:]:
                (pa, ca), (pb, cb) = bodies[a], bodies[b]
                ok = (np.minimum(ca, cb) >= self.min_confidence) \
                    & np.isfinite(pa).all(axis=1) & np.isfinite(pb).all(axis=1)
                if ok.sum() < 3:
                    continue
                d = float(np.linalg.norm(pa[ok] - pb[ok], axis=1).mean())
                r = self.pairs.setdefault((a, b), Residual())
                alpha = 1.0 if r.count == 0 else \
                    1.0 - math.exp(-max(t - r.last, 0.0) / self.tau)
                r.mean += alpha * (d - r.mean)
                r.count += 1
                r.last = t

    def ready(self) -> Dict[Pair, float]:
        """Residual (m) of each pair with enough instants."""
        return {p: r.mean for p, r in self.pairs.items()
                if r.count >= self.min_count}

    def wrong(self) -> Tuple[List[str], List[Pair]]:
        """(views with a wrong pose, pairs over threshold none is blamed
        for)."""
        ready = self.ready()
        views = sorted({v for p in ready for v in p})
        blamed = []
        for v in views:
            mine = [r for p, r in ready.items() if v in p]
            others = [r for p, r in ready.items() if v not in p]
            if others and min(mine) > self.threshold \
                    and np.median(others) <= self.threshold:
                blamed.append(v)
        unexplained = [p for p, r in ready.items() if r > self.threshold
                       and not set(p) & set(blamed)]
        return blamed, unexplained


Fit = Tuple[SensorPose, float, float]      # pose, residual before, after


class PoseFit:
    """A suspect view's pose fitted to the people the other views see.

    The fusion pairs a suspect view's skeletons (Skeleton frame) with the
    bodies other views agree on (world): ``add``. Over the last ``window``
    s, once ``min_instants`` pairs are in and the people moved (their
    centre's spread) ``min_motion`` m or more, ``fit`` fits the view's yaw
    and position (``refine_pose``; a still person could be anyone
    standing: no fit); ``good``: a fit whose mean residual is within
    ``threshold`` and half the residual before is the view's pose."""

    def __init__(self, window: float = 3.0, min_instants: int = 45,
                 min_motion: float = 0.3, threshold: float = 0.2,
                 min_confidence: float = 0.5) -> None:
        self.window = window
        self.min_instants = min_instants
        self.min_motion = min_motion
        self.threshold = threshold
        self.min_confidence = min_confidence
        self.pairs: Dict[str, Deque[Tuple[float, np.ndarray,
                                          np.ndarray]]] = {}

    def add(self, t: float, view: str, sensor: np.ndarray,
            world: np.ndarray, confidence: np.ndarray) -> None:
        """One skeleton of ``view`` (15, 3) and the others' body (15, 3)
        at ``t``; joints under ``min_confidence`` or missing are left
        out."""
        ok = (confidence >= self.min_confidence) \
            & np.isfinite(sensor).all(axis=1) & np.isfinite(world).all(axis=1)
        if ok.sum() < 3:
            return
        pairs = self.pairs.setdefault(view, collections.deque())
        pairs.append((t, sensor[ok], world[ok]))
        while pairs and pairs[0][0] < t - self.window:
            pairs.popleft()

    def fit(self, view: str, pose: SensorPose) -> Optional[Fit]:
        """(fitted pose, residual before, after) of ``view`` from its
        pairs, or None (too few, or too still)."""
        pairs = self.pairs.get(view, ())
        if len(pairs) < self.min_instants:
            return None
        centres = np.array([w.mean(axis=0)[:2] for _, _, w in pairs])
        if np.linalg.norm(np.ptp(centres, axis=0)) < self.min_motion:
            return None
        return refine_pose(pose, np.concatenate([s for _, s, _ in pairs]),
                           np.concatenate([w for _, _, w in pairs]))

    def good(self, fit: Fit) -> bool:
        """Whether ``fit`` explains the pairs (the view's pose)."""
        return fit[2] <= min(self.threshold, fit[1] / 2)

    def forget(self, view: str) -> None:
        """Drop ``view``'s pairs (its pose changed)."""
        self.pairs.pop(view, None)


def _level(pose: SensorPose, points: np.ndarray) -> np.ndarray:
    """Skeleton-frame points turned by the pose's pitch, not its yaw."""
    return (points * MIRROR) @ rotation(0.0, pose.pitch, SENSOR).T


def refine_pose(pose: SensorPose, sensor_points: np.ndarray,
                world_points: np.ndarray, trim: float = 0.2
                ) -> Tuple[SensorPose, float, float]:
    """(refined pose, mean residual before, after) of a sensor from its
    Skeleton-frame points and the same joints in world (another view's,
    or the fused body), (N, 3) each: yaw and position fitted in the plane,
    height from the mean, pitch kept; the worst ``trim`` share of points
    is left out of a second fit."""
    ok = np.isfinite(sensor_points).all(axis=1) \
        & np.isfinite(world_points).all(axis=1)
    q, w = _level(pose, sensor_points[ok]), world_points[ok]
    if len(q) < 3:
        raise ValueError('refine_pose needs 3 or more shared points, '
                         'not %d' % len(q))
    before = float(np.linalg.norm(pose.to_world(sensor_points[ok]) - w,
                                  axis=1).mean())
    refined: Optional[SensorPose] = None
    keep = np.ones(len(q), bool)
    for _ in range(2):
        refined = _fit(q[keep], w[keep], pose.pitch)
        err = np.linalg.norm(refined.to_world(sensor_points[ok]) - w, axis=1)
        keep = err <= np.quantile(err, 1.0 - trim)
    assert refined is not None
    after = float(np.linalg.norm(refined.to_world(sensor_points[ok]) - w,
                                 axis=1).mean())
    return refined, before, after


def _fit(q: np.ndarray, w: np.ndarray, pitch: float) -> SensorPose:
    """Yaw and translation taking level points ``q`` onto ``w``."""
    qc, wc = q - q.mean(axis=0), w - w.mean(axis=0)
    yaw = math.atan2((qc[:, 0] * wc[:, 1] - qc[:, 1] * wc[:, 0]).sum(),
                     (qc[:, 0] * wc[:, 0] + qc[:, 1] * wc[:, 1]).sum())
    c, s = math.cos(yaw), math.sin(yaw)
    rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    t = w.mean(axis=0) - rz @ q.mean(axis=0)
    return SensorPose(float(t[0]), float(t[1]), float(t[2]), yaw, pitch)


Skeletons = List[Tuple[float, np.ndarray, np.ndarray]]


def _track(samples: Skeletons, pose: Optional[SensorPose]) -> Track:
    """A Track of (stamp, Skeleton-frame joints, confidence) samples, in
    world when ``pose`` is given, else as they are."""
    track = Track(keep=math.inf)
    for stamp, positions, confidence in samples:
        p = np.asarray(positions, float)
        track.add(Sample(stamp, pose.to_world(p) if pose else p,
                         np.asarray(confidence, float), 0.0))
    return track


def shared_points(target: Skeletons, others: Dict[str, Skeletons],
                  poses: Dict[str, SensorPose], rate: float = 30.0,
                  min_confidence: float = 0.5
                  ) -> Tuple[np.ndarray, np.ndarray]:
    """(target's Skeleton-frame joints, the same joints in world from the
    other views), (N, 3) each: at instants ``rate`` Hz apart where the
    target and another view see a joint with ``min_confidence``, the
    other views' mean."""
    mine = _track(target, None)
    theirs = [_track(s, poses[v]) for v, s in sorted(others.items())]
    if len(mine.samples) < 2:
        return np.zeros((0, 3)), np.zeros((0, 3))
    start, end = mine.samples[0].stamp, mine.samples[-1].stamp
    sensor, world = [], []
    for t in np.arange(math.ceil(start * rate), end * rate) / rate:
        a = mine.at(t)
        refs = [r for r in (tr.at(t) for tr in theirs) if r is not None]
        if a is None or not refs:
            continue
        seen = np.array([r.confidence >= min_confidence for r in refs])
        pts = np.array([np.nan_to_num(r.positions) for r in refs])
        count = seen.sum(axis=0)
        ok = (a.confidence >= min_confidence) & (count > 0)
        mean = (pts * seen[..., None]).sum(axis=0) / np.maximum(count, 1)[
            :, None]
        sensor.append(a.positions[ok])
        world.append(mean[ok])
    if not sensor:
        return np.zeros((0, 3)), np.zeros((0, 3))
    return np.concatenate(sensor), np.concatenate(world)
