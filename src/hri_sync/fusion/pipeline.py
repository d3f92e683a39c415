"""The fusion loop: skeletons of several views in, fused people out at
common instants on the global clock, on an injected clock.

``add`` takes each view's skeleton as it arrives (its global capture
stamp, Skeleton-frame joints, confidences and the stamp's 95 %
uncertainty); ``poll`` fuses every instant ``k / rate`` that is ready:
every live view has a sample at or after it (so interpolation, not
extrapolation, brings each view there), or a view is late past its own
period plus its p95 pipeline latency (it is then extrapolated a little or
left out). A stalled view or one with a lost clock is not waited for.
Each view's tracker profile (hri_sync.fusion.profile) dates its skeletons
(stamp minus the tracker's delay) and corrects its joints first.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable, Dict, Hashable, List, Optional, Tuple

import numpy as np

from hri_sync.fusion.align import Sample, Track
from hri_sync.fusion.associate import Associator, Key
from hri_sync.fusion.calibration import Residuals
from hri_sync.fusion.frames import SensorPose
from hri_sync.fusion.fuse import FuseParams, Fused, Observation, fuse
from hri_sync.fusion.profile import Profile
from hri_sync.fusion.views import HealthParams, ViewHealth


@dataclass
class FusionParams:
    """Everything the fusion is tuned by."""

    rate: float = 30.0                  # Hz, common instants
    max_extrapolation: float = 0.04     # s past a view's newest sample
    max_gap: float = 0.25               # s between samples interpolated
    wait_margin: float = 0.005          # s past a view's expected arrival
    suspect_weight: float = 0.1         # a wrong-pose view's weight
    skip_after: float = 1.0             # s behind the newest: skip ahead
    fuse: FuseParams = field(default_factory=FuseParams)
    health: HealthParams = field(default_factory=HealthParams)
    gate: float = 0.5                   # m, association (associate.py)
    residual_threshold: float = 0.2     # m, wrong pose (calibration.py)


@dataclass
class Person:
    """One fused person at an instant."""

    person: int
    body: Fused
    newest: float               # newest capture used (global, s)


@dataclass
class Frame:
    """The fused people at one instant."""

    stamp: float                # the instant (global, s)
    people: List[Person]
    published: float            # clock at output


class Fusion:
    """Views' skeletons to fused people."""

    def __init__(self, poses: Dict[str, SensorPose],
                 params: Optional[FusionParams] = None,
                 clock: Callable[[], float] = lambda: 0.0,
                 profiles: Optional[Dict[str, Profile]] = None) -> None:
        self.params = params or FusionParams()
        self.clock = clock
        self.poses = dict(poses)
        self.profiles = {v: (profiles or {}).get(v) or Profile()
                         for v in poses}
        self.health = {v: ViewHealth(self.params.health) for v in poses}
        self.tracks: Dict[Key, Track] = {}
        self.associator = Associator(gate=self.params.gate)
        self.residuals = Residuals(threshold=self.params.residual_threshold)
        self.next_k: Optional[int] = None

    def add(self, view: str, user: Hashable, stamp: float,
            positions: np.ndarray, confidence: np.ndarray,
            uncertainty: float) -> Optional[str]:
        """One skeleton as it arrives; the reason when it is left out.
        ``stamp``: global capture time; ``positions``: Skeleton frame;
        ``uncertainty``: inf when the view's clock model is lost."""
        if view not in self.poses:
            return 'unknown_view'
        health = self.health[view]
        if not math.isfinite(stamp) or math.isnan(uncertainty):
            health.reject('bad_stamp')
            return 'bad_stamp'
        positions = np.array(positions, float).reshape(-1, 3)
        confidence = np.nan_to_num(np.array(confidence, float), nan=0.0)
        missing = ~np.isfinite(positions).all(axis=1)
        confidence[missing] = 0.0
        profile = self.profiles[view]
        stamp -= profile.delay
        health.arrived(self.clock(), stamp, uncertainty, int(missing.sum()))
        uncertainty += profile.delay_spread
        world = self.poses[view].to_world(positions)
        world[missing] = np.nan
        world = profile.correct(world)
        track = self.tracks.setdefault(
            (view, user), Track(max_gap=self.params.max_gap))
        if not track.add(Sample(stamp, world, np.clip(confidence, 0, 1),
                                uncertainty)):
            health.reject('repeated_stamp')
            return 'repeated_stamp'
        return None

    def set_pose(self, view: str, pose: SensorPose) -> None:
        """A view's new pose (a refined calibration)."""
        self.poses[view] = pose

    def _newest(self, view: str) -> float:
        stamps = self.health[view].stamps
        return stamps[-1] if stamps else -math.inf

    def _ready(self, t: float, now: float) -> bool:
        """Whether instant ``t`` can be fused now."""
        live = [v for v, h in self.health.items() if h.arrivals
                and not h.stalled(now) and not h.clock_lost()]
        if not live:
            return False
        for v in live:
            h = self.health[v]
            due = t + h.period() + h.latency() + self.params.wait_margin
            if self._newest(v) < t and now < due:
                return False
        return True

    def poll(self) -> List[Frame]:
        """Fuse every instant that is ready; the frames in time order."""
        now = self.clock()
        newest = max((self._newest(v) for v in self.health),
                     default=-math.inf)
        if not math.isfinite(newest):
            return []
        rate = self.params.rate
        skip = math.ceil((newest - self.params.skip_after) * rate)
        if self.next_k is None or self.next_k < skip:
            self.next_k = max(skip, math.ceil(min(
                self._newest(v) for v in self.health
                if self.health[v].arrivals) * rate))
        frames = []
        while self._ready(self.next_k / rate, now):
            frames.append(self._fuse_at(self.next_k / rate))
            self.next_k += 1
        return frames

    def _observe(self, t: float) -> Dict[Key, Tuple[Observation, float]]:
        """Each usable track's observation at ``t`` and its newest stamp."""
        out = {}
        for key, track in list(self.tracks.items()):
            view = key[0]
            if track.newest < t - 2.0:
                del self.tracks[key]
                continue
            if self.health[view].clock_lost():
                continue
            a = track.at(t, self.params.max_extrapolation)
            if a is None or not np.isfinite(a.positions).any():
                continue
            weight = self.params.suspect_weight \
                if self.health[view].wrong_pose else 1.0
            profile = self.profiles[view]
            out[key] = (Observation(view, a.positions, a.confidence,
                                    a.speed, a.uncertainty, weight,
                                    profile.sigma, profile.sigma_common),
                        a.newest)
        return out

    def _fuse_at(self, t: float) -> Frame:
        """Associate, fuse and check the calibration at instant ``t``."""
        obs = self._observe(t)
        ids = self.associator.assign(
            t, {k: o.positions for k, (o, _) in obs.items()})
        groups: Dict[int, List[Key]] = {}
        for key, pid in ids.items():
            groups.setdefault(pid, []).append(key)
        people = []
        for pid in sorted(groups):
            views = [obs[k][0] for k in groups[pid]]
            body = fuse(views, self.params.fuse)
            self.associator.update(pid, body.positions, t)
            self.residuals.add(t, {o.view: (o.positions, o.confidence)
                                   for o in views})
            newest = max((obs[k][1] for k in groups[pid]
                          if k[0] in body.views), default=t)
            people.append(Person(pid, body, newest))
        blamed, _ = self.residuals.wrong()
        for view, health in self.health.items():
            health.wrong_pose = view in blamed
        return Frame(t, people, self.clock())

    def faults(self) -> Dict[str, List[Tuple[str, str]]]:
        """Each view's faults now (views.ViewHealth.faults)."""
        now = self.clock()
        return {v: h.faults(now) for v, h in sorted(self.health.items())}
