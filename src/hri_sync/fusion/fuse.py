"""One joint from the views that see it, with a 95 % bound.

Each view's joint is weighted by the inverse of its variance: the
view's own error at that confidence, ``sigma / confidence`` (m, one axis),
plus the timing term, the view's stamp uncertainty (95 %, s) times the
joint's speed; times the view's weight (1, less for a suspect view). A joint
hidden in one view (low confidence) thus comes from the views that see
it. With three or more views a joint farther than ``outlier`` m from the
views' median is left out. The fused joint's 95 % bound is
``k * sqrt(sigma_fused ** 2 + sigma_common ** 2) + uncertainty * speed``:
the views' own errors averaged by the weights, the error they share
(``sigma_common``, hri_sync.fusion.profile) that no weighting removes, and
the timing part from the weight-averaged stamp uncertainty and speed.
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
    sigma: float = 0.05         # m, one axis, at confidence 1
    sigma_common: float = 0.0   # m, one axis, shared by all views


@dataclass
class FuseParams:
    """How joints are fused."""

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
             ) -> Tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray,
                        np.ndarray]:
    """Points, inverse variances, timing terms, own and shared sigmas
    (at the joint's confidence) of the views usable for joint ``j``."""
    rows = [o for o in obs if np.isfinite(o.positions[j]).all()
            and o.confidence[j] >= p.min_confidence and o.weight > 0]
    pts = np.array([o.positions[j] for o in rows]).reshape(-1, 3)
    conf = np.maximum([o.confidence[j] for o in rows], p.min_confidence)
    timing = np.array([o.uncertainty * o.speed[j] for o in rows])
    sigma = np.array([[o.sigma, o.sigma_common] for o in rows]
                     ).reshape(-1, 2)
    sigma[:, 0] /= conf
    var = sigma[:, 0] ** 2 + (timing / p.k) ** 2
    w = np.array([o.weight for o in rows]) / var
    return pts, w, timing, conf, sigma


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
        pts, w, timing, conf, sigma = _weights(obs, j, p)
        if not len(pts):
            continue
        keep = _drop_outliers(pts, p.outlier)
        pts, w, timing, conf, sigma = (pts[keep], w[keep], timing[keep],
                                       conf[keep], sigma[keep])
        out.positions[j] = (w[:, None] * pts).sum(axis=0) / w.sum()
        out.confidence[j] = conf.max()
        own = (w ** 2 * sigma[:, 0] ** 2).sum() / w.sum() ** 2
        common = ((w * sigma[:, 1]).sum() / w.sum()) ** 2
        out.bound[j] = p.k * np.sqrt(own + common) \
            + (w * timing).sum() / w.sum()
        views = [o.view for o in obs if np.isfinite(o.positions[j]).all()
                 and o.confidence[j] >= p.min_confidence and o.weight > 0]
        used.update(v for v, k in zip(views, keep) if k)
    out.views = sorted(used)
    return out
