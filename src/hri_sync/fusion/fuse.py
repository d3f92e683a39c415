"""One joint from the views that see it, with a 95 % bound.

Each view's joint is weighted by the inverse of its variance: the
view's own error at that confidence, ``sigma * confidence ** -power`` (m,
one axis; the tracker's profile) times ``scale`` (where the view stands:
its arms' error grows as it sees more of the body's back), plus the
timing term, the view's stamp uncertainty (95 %, s) times the joint's
speed; times the view's weight (1, less for a suspect view). A joint
hidden in one view (low confidence) thus comes from the views that see
it. With three or more views a joint farther than ``outlier`` m from the
views' median is left out; then each view's
weight is scaled by its agreement with the others, ``1 / (1 + (d / (c *
s)) ** 2)`` (Cauchy, c = ``agreement``: 2.385, its usual 95 %-efficient
constant), d its distance from the fused joint, s its expected error,
``agreement_steps`` times. The fused joint's 95 % bound is
``k * sqrt(sigma_fused ** 2 + sigma_common ** 2) + uncertainty * speed``:
the views' own errors averaged by the weights, the error they share
(``sigma_common``, hri_sync.fusion.profile) that no weighting removes, and
the timing part from the weight-averaged stamp uncertainty and speed.
Where the views scatter about their mean (weighted by their expected
errors, before the outlier cut and the agreement: the Birge ratio, the
chi-square over its degrees of freedom) more than those errors allow,
the two error terms are scaled by that ratio: the tracker errs more than
its profile says, alike in what the views share.
A joint no view gives at ``min_confidence`` or more is fused from the
views' guesses below it (a tracker's estimate of a joint it does not
see), each at the error the profile gives its least confidence, and
published at confidence 0; NaN only where no view has it at all.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Dict, List, Optional

import numpy as np

from hri_sync.dance_off.joints import NUM_JOINTS

LEAST_CONFIDENCE = 0.05     # a joint below it is not used; the floor of
                            # the error model's confidence


def own_sigma(sigma, confidence, power, least=LEAST_CONFIDENCE):
    """A view's own error (m, one axis) at ``confidence``: the tracker
    profile's ``sigma * confidence ** -power``, the confidence floored at
    ``least`` (arrays broadcast)."""
    return sigma * np.maximum(confidence, least) ** -power


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
    power: float = 1.0          # sigma grows as confidence ** -power
    scale: Optional[np.ndarray] = None  # (15,) sigma multipliers; None: 1


@dataclass
class FuseParams:
    """How joints are fused."""

    min_confidence: float = LEAST_CONFIDENCE
    k: float = 2.8              # 95 % of a 3-D normal: sqrt(chi2(3, .95))
    outlier: float = 0.3        # m
    agreement: float = 2.385    # Cauchy constant (0: no reweighting)
    agreement_steps: int = 3


@dataclass
class Fused:
    """A fused body."""

    positions: np.ndarray       # (15, 3), NaN: no view has the joint
    confidence: np.ndarray      # (15,)
    bound: np.ndarray           # (15,) m, 95 %
    views: List[str]            # the views that gave a joint
    # (15,) the views' Birge ratio squared: their scatter in units of
    # their expected errors
    scatter: np.ndarray = field(
        default_factory=lambda: np.ones(NUM_JOINTS))
    # (15,) m, one axis: the error the bound is made of, timing apart
    sigma: np.ndarray = field(
        default_factory=lambda: np.full(NUM_JOINTS, np.nan))


def _stack(obs: List[Observation], p: FuseParams) -> Dict[str, np.ndarray]:
    """The views' arrays (views first) and each joint's inverse variance
    (0 where a view cannot give the joint)."""
    a = {'pts': np.array([o.positions for o in obs], float),
         'conf': np.array([o.confidence for o in obs], float),
         'timing': np.array([o.uncertainty * o.speed for o in obs], float)}
    weight = np.array([o.weight for o in obs], float)[:, None]
    finite = np.isfinite(a['pts']).all(axis=2) & (weight > 0)
    usable = finite & (a['conf'] >= p.min_confidence)
    a['guessed'] = ~usable.any(axis=0)
    usable |= finite & a['guessed']
    a['own'] = own_sigma(np.array([o.sigma for o in obs])[:, None],
                         a['conf'], np.array([o.power for o in obs])[:, None],
                         p.min_confidence) \
        * np.array([np.ones(NUM_JOINTS) if o.scale is None else o.scale
                    for o in obs])
    a['common'] = np.array([o.sigma_common for o in obs])[:, None] \
        + np.zeros_like(a['conf'])
    var = a['own'] ** 2 + (a['timing'] / p.k) ** 2
    a['w'] = np.where(usable, weight / var, 0.0)
    a['scatter'] = _scatter(a['pts'], a['w'])
    a['w'] *= _kept(a['pts'], usable, p.outlier)
    a['w'] = _agreed(a['pts'], a['w'], np.sqrt(var), p)
    return a


def _agreed(pts: np.ndarray, w: np.ndarray, spread: np.ndarray,
            p: FuseParams) -> np.ndarray:
    """The weights ``w`` (views, 15) scaled by each view's agreement with
    the fused joint (Cauchy on its distance in units of ``spread``, its
    expected error), ``p.agreement_steps`` times."""
    out = w
    pts = np.nan_to_num(pts)
    for _ in range(p.agreement_steps if p.agreement > 0 else 0):
        mean = _mean(pts, out)
        d = np.linalg.norm(pts - mean, axis=2) / (p.agreement * spread)
        out = w / (1.0 + d ** 2)
    return out


def _mean(pts: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Each joint's mean (15, 3) of the views' finite ``pts`` (views, 15,
    3) weighted by ``w`` (views, 15); 0 where no view has weight."""
    total = w.sum(axis=0)
    return (w[..., None] * pts).sum(axis=0) \
        / np.where(total > 0, total, 1.0)[:, None]


def _scatter(pts: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Per joint, the views' scatter about their weighted mean in units
    of their expected errors (the Birge ratio squared: chi-square over
    its degrees of freedom; 1 where fewer than two views give it)."""
    n = (w > 0).sum(axis=0)
    pts = np.nan_to_num(pts)
    chi2 = (w * ((pts - _mean(pts, w)) ** 2).sum(axis=2)).sum(axis=0)
    return np.where(n >= 2, chi2 / (3 * np.maximum(n - 1, 1)), 1.0)


def _kept(pts: np.ndarray, usable: np.ndarray, limit: float) -> np.ndarray:
    """Mask of the views' joints within ``limit`` of the views' median,
    for the joints three or more views give (all usable ones elsewhere,
    and where fewer than two would be left)."""
    keep = usable.copy()
    many = usable.sum(axis=0) >= 3
    if not many.any():
        return keep
    masked = np.where(usable[..., None], pts, np.nan)[:, many]
    ordered = np.sort(masked, axis=0)            # NaN last
    n = usable[:, many].sum(axis=0)[None, :, None]
    median = (np.take_along_axis(ordered, (n - 1) // 2, axis=0)
              + np.take_along_axis(ordered, n // 2, axis=0))[0] / 2
    near = np.linalg.norm(masked - median, axis=2) <= limit
    near &= usable[:, many]
    enough = near.sum(axis=0) >= 2
    keep[:, many] = np.where(enough, near, usable[:, many])
    return keep


def fuse(obs: List[Observation], p: FuseParams,
         inflate: Optional[np.ndarray] = None) -> Fused:
    """The fused body of one person from its views' observations; its
    bound's error model scaled (variance) by the views' scatter, or by
    ``inflate`` (per joint) where that is larger."""
    a = _stack(obs, p)
    w = a['w']
    total = w.sum(axis=0)
    has = total > 0
    safe = np.where(has, total, 1.0)
    positions = _mean(np.nan_to_num(a['pts']), w)
    own = (w ** 2 * a['own'] ** 2).sum(axis=0) / safe ** 2
    common = ((w * a['common']).sum(axis=0) / safe) ** 2
    held = np.ones(NUM_JOINTS) if inflate is None else inflate
    sigma = np.sqrt(own + common)
    bound = p.k * sigma * np.sqrt(np.maximum(np.maximum(a['scatter'], held),
                                             1.0)) \
        + (w * a['timing']).sum(axis=0) / safe
    confidence = np.where((w > 0) & ~a['guessed'], a['conf'], 0.0).max(axis=0)
    positions[~has] = np.nan
    bound[~has] = np.nan
    sigma[~has] = np.nan
    views = sorted({o.view for o, used in zip(obs, (w > 0).any(axis=1))
                    if used})
    return Fused(positions, np.where(has, confidence, 0.0), bound, views,
                 a['scatter'], sigma)
