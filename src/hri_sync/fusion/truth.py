"""How far each view and the fused body are from the motion rendered.

The fusion demo and bench place one motion in the world (``world_motion``)
and render it through virtual Kinects around it. In the demo each virtual
Kinect shows the motion at the true time since ``epoch``, and a skeleton's
stamp is global time, which on a host that serves its own time is the true
time: the stamp names the truth it shows. ``TruthScore`` takes what each
source (a view, or the fused body) publishes and keeps its joint errors,
its people that are nobody (a tracker's ghost, a fusion's duplicate), its
pipeline latency and, for the fused body, the share of the truth inside its
95 % bounds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Dict, List, Optional, Sequence

import numpy as np

from hri_sync.dance_off.joints import INDEX
from hri_sync.dance_off.motion import Motion
from hri_sync.fusion.associate import body_distance
from hri_sync.fusion.views import RULES

PROFILED = ' profiled'   # a view through its tracker's profile


def world_motion(motion: Motion) -> Motion:
    """The motion in world (REP 103, floor z = 0, mean torso at the
    origin, the dancer facing +x where the motion's own sensor was)."""
    p = motion.positions
    torso = p[:, INDEX['torso']].mean(axis=0)
    world = np.stack([-(p[..., 2] - torso[2]), p[..., 0] - torso[0],
                      p[..., 1] + 1.0], axis=-1)
    return Motion(motion.times - motion.times[0], world, name=motion.name)


@dataclass
class Body:
    """One person as a source gives them, in world."""

    positions: np.ndarray                 # (15, 3) m
    confidence: np.ndarray                # (15,)
    bound: Optional[np.ndarray] = None    # (15,) m: the 95 % bound
    newest: Optional[float] = None        # s after the stamp: the newest
                                          # capture a fused body used


@dataclass
class SourceScore:
    """What one source gave over the scored time."""

    errors: List[float] = field(default_factory=list)   # m, per joint
    latencies: List[float] = field(default_factory=list)  # s
    fresh: List[float] = field(default_factory=list)  # s after the newest
                                                      # capture used
    instants: int = 0
    others: int = 0         # bodies farther than ``near`` from the truth
    inside: int = 0         # joints whose truth is inside their bound
    bounded: int = 0


class TruthScore:
    """Each source's joint error against the truth at its stamps.

    A body within ``near`` m of the truth along the floor (the fusion's
    own ``body_distance``) is the person; the nearest one per message is
    scored, every other body counted in ``others``. Stamps ``since`` s
    after ``epoch`` and on are scored, for ``seconds``.
    """

    def __init__(self, truth: Motion, epoch: float, since: float,
                 seconds: float, near: float = 0.5):
        self.truth, self.epoch, self.near = truth, epoch, near
        self.since, self.until = since, since + seconds
        self.sources: Dict[str, SourceScore] = {}

    def truth_at(self, stamp: float) -> np.ndarray:
        """The world joints (15, 3) at global ``stamp`` (the motion loops,
        as the virtual Kinect's does)."""
        return self.truth.positions_at([stamp - self.epoch], 'loop')[0]

    def scoring(self, stamp: float) -> bool:
        """Whether ``stamp`` is in the scored time."""
        return self.since <= stamp - self.epoch < self.until

    def done(self, stamp: float) -> bool:
        """Whether the scored time is over at global ``stamp``."""
        return stamp - self.epoch >= self.until

    def add(self, source: str, stamp: float, bodies: Sequence[Body],
            latency: float) -> None:
        """The bodies ``source`` gave for global ``stamp``, received
        ``latency`` s after the instant they were captured at."""
        score = self.sources.setdefault(source, SourceScore())
        if not self.scoring(stamp):
            return
        score.instants += 1
        score.latencies.append(latency)
        truth = self.truth_at(stamp)
        gaps = [body_distance(b.positions, truth) for b in bodies]
        near = [i for i, g in enumerate(gaps) if g <= self.near]
        score.others += len(bodies) - min(len(near), 1)
        if not near:
            return
        body = bodies[min(near, key=lambda i: gaps[i])]
        if body.newest is not None:
            score.fresh.append(latency - body.newest)
        given = (body.confidence > 0) & np.isfinite(body.positions).all(axis=1)
        errors = np.linalg.norm(body.positions - truth, axis=1)
        score.errors.extend(float(e) for e in errors[given])
        if body.bound is not None:
            score.bounded += int(given.sum())
            score.inside += int((errors <= body.bound)[given].sum())

    def summary(self) -> Dict[str, Dict[str, float]]:
        """Per source: ``mean_m``, ``p95_m``, ``joints`` (scored),
        ``instants``, ``others``, ``latency_p50_ms``, ``latency_p95_ms``
        (after the instant), and where given ``bound_coverage`` and
        ``latency_newest_p95_ms`` (after the newest capture a fused body
        used); NaN where nothing came."""
        out = {}
        for name, s in sorted(self.sources.items()):
            err = np.array(s.errors)
            lat = np.array(s.latencies) * 1e3
            row = {'mean_m': _stat(err, np.mean), 'p95_m': _stat(
                err, lambda a: np.percentile(a, 95)), 'joints': len(err),
                'instants': s.instants, 'others': s.others,
                'latency_p50_ms': _stat(lat, np.median),
                'latency_p95_ms': _stat(lat, lambda a: np.percentile(a, 95))}
            if s.bounded:
                row['bound_coverage'] = round(s.inside / s.bounded, 4)
            if s.fresh:
                row['latency_newest_p95_ms'] = _stat(
                    np.array(s.fresh) * 1e3, lambda a: np.percentile(a, 95))
            out[name] = row
        return out


def rules_line(counts: Dict[str, Dict[str, str]]) -> str:
    """What the fusion's side rules did to each view (``counts``: view ->
    its status's values of hri_sync.fusion.views.RULES, as received), for
    a terminal."""
    return 'fusion rules, instants per view since it started: ' + '; '.join(
        '%s: %s' % (view, ', '.join('%s %s' % (rule, got[rule])
                                    for rule in RULES if rule in got))
        for view, got in sorted(counts.items())) if counts else \
        'fusion rules: no view status received (/diagnostics)'


def _stat(values: np.ndarray, f) -> float:
    return round(float(f(values)), 4) if len(values) else math.nan


def table(summary: Dict[str, Dict[str, float]], fused: str,
          baseline: str = PROFILED) -> List[str]:
    """The summary as lines for a terminal: each source, then how much
    better the fused body is than the best view (the best of the sources
    named ``VIEW`` + ``baseline``, when there are such: the views as the
    fusion takes them; else of every other source)."""
    lines = ['%-16s %9s %9s %8s %7s %14s' % (
        'source', 'mean (m)', 'p95 (m)', 'instants', 'others',
        'latency p95 (ms)')]
    for name, row in sorted(summary.items(), key=lambda kv: kv[0] == fused):
        lines.append('%-16s %9.3f %9.3f %8d %7d %14.1f' % (
            name, row['mean_m'], row['p95_m'], row['instants'],
            row['others'], row['latency_p95_ms']))
    if fused not in summary:
        lines.append('%-16s nothing received' % fused)
    views = {k: v for k, v in summary.items() if k != fused}
    ours = {k: v for k, v in views.items() if k.endswith(baseline)} or views
    ours = {k: v for k, v in ours.items() if not math.isnan(v['mean_m'])}
    best = min(ours, key=lambda k: ours[k]['mean_m'], default=None)
    got = summary.get(fused)
    if got and best and not math.isnan(got['mean_m']):
        slowest = max(v['latency_p95_ms'] for v in views.values())
        lines.append('fused: %.1f %% below the best view (%s, %.3f m); '
                     '%.1f %% of the truth inside its 95 %% bounds; latency '
                     'p95 %.1f ms beyond the slowest view\'s' % (
                         100 * (1 - got['mean_m'] / ours[best]['mean_m']),
                         best, ours[best]['mean_m'],
                         100 * got.get('bound_coverage', math.nan),
                         got['latency_p95_ms'] - slowest))
        if 'latency_newest_p95_ms' in got:
            lines[-1] += (' after the instant, %.1f ms after the newest '
                          'capture used' % (got['latency_newest_p95_ms']
                                            - slowest))
        if 'fusion_node_latency_p95_ms' in got:
            lines[-1] += ('; the fusion node\'s own latency p95 %.1f ms '
                          '(/diagnostics)' % got['fusion_node_latency_p95_ms'])
    return lines
