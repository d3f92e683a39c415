"""One joint from the views that see it, with a 95 % bound.

Each view's joint is weighted by the inverse of its variance: the
tracker's error at that confidence, ``sigma / confidence`` (m), plus the
timing term, the view's stamp uncertainty (95 %, s) times the joint's
speed; times the view's weight (1, less for a suspect view). A joint
hidden in one view (low confidence) thus comes from the views that see
it. With three or more views a joint farther than ``outlier`` m from the
views' median is left out. The fused joint's 95 % bound is
``k * sigma_fused + uncertainty * speed``: the measurement part from the
weights, the timing part from the weight-averaged stamp uncertainty and
speed.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import List, Set, Tuple

import numpy as np


@dataclass
class Observation:
    """A view's aligned skeleton of one person, in world."""

    view: str
    positions: np.ndarray       # (15, 3)
    confidence: np.ndarray      # (15,)
    speed: np.ndarray           # (15,) m/s
    uncertainty: float          # s, 95 %
    weight: float = 1.0         # the view's trust (calibration)


@dataclass
class FuseParams:
    """The error model of a view's joint."""

    sigma: float = 0.05         # m, one axis, at confidence 1
    min_confidence: float = 0.05
    k: float = 2.8              # 95 % of a 3-D normal: sqrt(chi2(3, .95))
    outlier: float = 0.3        # m


@dataclass
class Fused:
    """A fused body."""

    positions: np.ndarray       # (15, 3), NaN: no view has the joint
    confidence: np.ndarray      # (15,)
    bound: np.ndarray           # (15,) m, 95 %
    views: List[str]            # the views that gave a joint


def _weights(obs: List[Observation], j: int, p: FuseParams
             ) -> Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Points, inverse variances, timing terms and confidences of the
    views usable for joint ``j``."""
    rows = [o for o in obs if np.isfinite(o.positions[j]).all()
            and o.confidence[j] >= p.min_confidence and o.weight > 0]
    pts = np.array([o.positions[j] for o in rows]).reshape(-1, 3)
    conf = np.array([o.confidence[j] for o in rows])
    timing = np.array([o.uncertainty * o.speed[j] for o in rows])
    var = (p.sigma / np.maximum(conf, p.min_confidence)) ** 2 \
        + (timing / p.k) ** 2
    w = np.array([o.weight for o in rows]) / var
    return pts, w, timing, conf


def _drop_outliers(pts: np.ndarray, limit: float) -> np.ndarray:
    """Mask of the points within ``limit`` of the points' median (3+)."""
    keep = np.ones(len(pts), bool)
    if len(pts) < 3:
        return keep
    keep = np.linalg.norm(pts - np.median(pts, axis=0), axis=1) <= limit
    return keep if keep.sum() >= 2 else np.ones(len(pts), bool)


def fuse(obs: List[Observation], p: FuseParams) -> Fused:
    """The fused body of one person from its views' observations."""
    n = obs[0].positions.shape[0]
    out = Fused(np.full((n, 3), np.nan), np.zeros(n), np.full(n, np.nan),
                [])
    used: Set[str] = set()
    for j in range(n):
        pts, w, timing, conf = _weights(obs, j, p)
        if not len(pts):
            continue
        keep = _drop_outliers(pts, p.outlier)
        pts, w, timing, conf = pts[keep], w[keep], timing[keep], conf[keep]
        out.positions[j] = (w[:, None] * pts).sum(axis=0) / w.sum()
        out.confidence[j] = conf.max()
        sigma_meas = p.sigma / np.maximum(conf, p.min_confidence)
        meas = np.sqrt((w ** 2 * sigma_meas ** 2).sum()) / w.sum()
        out.bound[j] = p.k * meas + (w * timing).sum() / w.sum()
        views = [o.view for o in obs if np.isfinite(o.positions[j]).all()
                 and o.confidence[j] >= p.min_confidence and o.weight > 0]
        used.update(v for v, k in zip(views, keep) if k)
    out.views = sorted(used)
    return out
