"""A fused person's joints through a constant-velocity Kalman filter.

Each joint (each axis alike) is a position and a velocity driven by an
acceleration that is white from one instant to the next, ``accel`` m/s^2
(one axis, per step). The fused joint is its measurement, at the variance
the fusion gives it (``sigma`` m, one axis). A joint missing, an instant
more than ``max_gap`` s after the last, or a measurement farther than
``gate`` of its predicted spread from the prediction (a jump: arms
exchanged back, a tracker's user given to another person) starts the
joint over from the measurement. The fusion moves each joint's 95 %
bound with it (hri_sync.fusion.pipeline; docs/fusion.md has what the
filter gains).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from hri_sync.dance_off.joints import NUM_JOINTS

START_SPEED = 1.0   # m/s, one axis: a joint's velocity spread as it starts


@dataclass
class SmoothParams:
    """The motion model."""

    accel: float = 30.0         # m/s^2, one axis, per step (0: off)
    gate: float = 5.0           # predicted spreads: a jump beyond
    max_gap: float = 0.2        # s between instants filtered across


@dataclass
class Smoother:
    """One person's joints, filtered instant by instant."""

    params: SmoothParams = field(default_factory=SmoothParams)
    t: Optional[float] = None
    x: np.ndarray = field(default_factory=lambda: np.full((NUM_JOINTS, 3),
                                                          np.nan))
    v: np.ndarray = field(default_factory=lambda: np.zeros((NUM_JOINTS, 3)))
    # each joint's covariance of (position, velocity), one axis
    pxx: np.ndarray = field(default_factory=lambda: np.zeros(NUM_JOINTS))
    pxv: np.ndarray = field(default_factory=lambda: np.zeros(NUM_JOINTS))
    pvv: np.ndarray = field(default_factory=lambda: np.zeros(NUM_JOINTS))

    def update(self, t: float, z: np.ndarray, sigma: np.ndarray) -> np.ndarray:
        """The filtered joints at ``t`` from the fused ``z`` (15, 3; NaN:
        missing) whose error is ``sigma`` (15,) m, one axis."""
        if self.params.accel <= 0:
            return z
        r = np.nan_to_num(np.asarray(sigma, float), nan=1.0) ** 2
        q = self.params.accel ** 2
        dt = math.inf if self.t is None else t - self.t
        gap = not 0 < dt <= self.params.max_gap
        dt, self.t = (0.0 if gap else dt), t
        xp = self.x + self.v * dt
        pxx = self.pxx + 2 * dt * self.pxv + dt * dt * self.pvv \
            + q * dt ** 4 / 4
        pxv = self.pxv + dt * self.pvv + q * dt ** 3 / 2
        pvv = self.pvv + q * dt * dt
        s = pxx + r
        with np.errstate(invalid='ignore'):
            jump = np.linalg.norm(z - xp, axis=1) > self.params.gate \
                * np.sqrt(3 * s)
        restart = gap | ~np.isfinite(z).all(axis=1) \
            | ~np.isfinite(xp).all(axis=1) | jump
        k1, k2 = pxx / s, pxv / s
        innovation = np.nan_to_num(z - xp)
        x = xp + k1[:, None] * innovation
        v = self.v + k2[:, None] * innovation
        self.pxx = np.where(restart, r, (1 - k1) * pxx)
        self.pxv = np.where(restart, 0.0, (1 - k1) * pxv)
        self.pvv = np.where(restart, START_SPEED ** 2, pvv - k2 * pxv)
        self.x = np.where(restart[:, None], z, x)
        self.v = np.where(restart[:, None], 0.0, v)
        return self.x.copy()
