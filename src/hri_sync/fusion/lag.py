"""A tracker filter's lag, joint by joint: each skeleton re-dated.

A tracker that smooths each joint with a one-euro filter (Casiez, Roussel
and Vogel, CHI 2012; the project's tracker: include/hri_sync/joint_filter.h)
lags each joint by about ``1 / (2 pi f)`` s, ``f`` its cutoff at the
time: ``min_cutoff``, plus ``beta`` per m/s of the filter's speed
estimate over ``dead_zone``. A fast joint lags 20 ms, a slower one 50 ms
or more, so one delay for the whole skeleton dates its fast joints too
early and its slow ones too late. ``FilterLag`` runs the filter's own
speed estimate (the distance between the means of the last two blocks of
``block`` s of samples, low-passed at ``speed_cutoff`` Hz) on one view's
skeletons of one person as they come, and moves each joint along its
velocity (from the view's skeleton before) to where it was the profile's
``delay`` s before the capture: by ``(lag - delay) * velocity``. The lag
is capped at ``max_lag``: a slow, swaying joint's filter damps it more
than it delays it. A joint that moved faster than ``max_speed`` since
the skeleton before (faster than a limb moves: 9.7 m/s at most in the
project's motion-capture clips) jumped, the tracker having refitted it,
and is left where it is. Skeletons are taken in the view's own frame, so
a view whose pose is refitted keeps its state.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import asdict, dataclass
from typing import Any, Deque, Dict, Tuple

import numpy as np


@dataclass
class FilterParams:
    """The tracker's one-euro filter, and the cap on its lag."""

    min_cutoff: float = 0.3     # Hz, a still joint's cutoff
    beta: float = 4.0           # Hz per m/s of speed over the dead zone
    dead_zone: float = 0.3      # m/s of block-mean speed taken as jitter
    block: float = 0.133        # s per block of the speed estimate
    speed_cutoff: float = 1.0   # Hz, the low-pass on the speed estimate
    max_lag: float = 0.07       # s, the lag's cap
    max_speed: float = 10.0     # m/s: a joint faster jumped (not moved)

    def to_dict(self) -> Dict[str, float]:
        """Plain values (a YAML param)."""
        return {k: round(v, 4) for k, v in asdict(self).items()}

    @classmethod
    def from_dict(cls, d: Dict[str, Any]) -> 'FilterParams':
        """FilterParams from ``to_dict``'s values (missing: defaults)."""
        if not isinstance(d, dict):
            raise ValueError('a profile filter is a dict: %r' % (d,))
        unknown = set(d) - set(asdict(cls()))
        if unknown:
            raise ValueError('unknown profile filter keys: %s'
                             % sorted(unknown))
        values = {k: float(v) for k, v in d.items()}
        if not all(math.isfinite(v) and v > 0 for v in values.values()):
            raise ValueError('profile filter values are finite and > 0: %r'
                             % d)
        return cls(**values)


def _alpha(cutoff: float, dt: float) -> float:
    """A first-order low-pass's smoothing factor at ``cutoff`` Hz."""
    return 1.0 / (1.0 + 1.0 / (2 * math.pi * cutoff * dt))


class FilterLag:
    """One view's skeletons of one person, re-dated joint by joint."""

    def __init__(self, params: FilterParams, delay: float,
                 max_gap: float = 0.25) -> None:
        self.params = params
        self.delay = delay
        self.max_gap = max_gap
        self.history: Deque[Tuple[float, np.ndarray]] = deque()
        self.speed = np.zeros(0)

    def lags(self) -> np.ndarray:
        """Each joint's lag now (s), from the speed estimate."""
        p = self.params
        cutoff = p.min_cutoff + p.beta * np.maximum(self.speed - p.dead_zone,
                                                    0.0)
        return np.minimum(1.0 / (2 * math.pi * cutoff), p.max_lag)

    def redate(self, stamp: float, positions: np.ndarray) -> np.ndarray:
        """``positions`` (joints, 3; the view's frame, NaN: missing) of the
        skeleton captured at ``stamp`` moved to where each joint was
        ``delay`` s before it. One not after the skeleton before (repeated,
        or late on the way) is not moved and leaves the estimate as it
        was; one after a gap over ``max_gap`` s starts it over (no move)."""
        positions = np.asarray(positions, float)
        last = self.history[-1] if self.history else None
        if last is not None and stamp <= last[0]:
            return positions.copy()
        if last is None or stamp - last[0] > self.max_gap \
                or last[1].shape != positions.shape:
            self.history.clear()
            self.speed = np.zeros(len(positions))
            self.history.append((stamp, positions))
            return positions.copy()
        dt = stamp - last[0]
        self.history.append((stamp, positions))
        while len(self.history) > 2 and \
                self.history[0][0] < stamp - 2 * self.params.block - 1e-9:
            self.history.popleft()
        a = _alpha(self.params.speed_cutoff, dt)
        speed = self._block_speed(stamp)
        known = np.isfinite(speed)
        self.speed[known] = a * speed[known] + (1 - a) * self.speed[known]
        velocity = (positions - last[1]) / dt
        shift = (self.lags() - self.delay)[:, None] * velocity
        with np.errstate(invalid='ignore'):
            jumped = np.linalg.norm(velocity, axis=1) > self.params.max_speed
        shift[jumped] = 0.0
        return np.where(np.isfinite(shift), positions + shift, positions)

    def _block_speed(self, stamp: float) -> np.ndarray:
        """Each joint's speed between the means of the last two blocks
        (from the last two samples when a block is empty); NaN where a
        joint is missing."""
        mid = stamp - self.params.block
        new = [(t, p) for t, p in self.history if t > mid]
        old = [(t, p) for t, p in self.history if t <= mid]
        if not old:
            new, old = new[-1:], new[-2:-1]
        t_new = np.mean([t for t, _ in new])
        t_old = np.mean([t for t, _ in old])
        with np.errstate(invalid='ignore'):
            p_new = np.mean([p for _, p in new], axis=0)
            p_old = np.mean([p for _, p in old], axis=0)
        return np.linalg.norm(p_new - p_old, axis=1) / (t_new - t_old)
