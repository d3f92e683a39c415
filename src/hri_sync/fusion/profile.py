"""A tracker's profile: how its joints differ from the true joints in a
way every view of it shares.

A skeleton tracker places joints by its own body model (its neck is not a
motion-capture neck) and filters them over time (its joints describe the
body ``delay`` s before the frame's capture). Views of one tracker share
these errors, so fusing views cannot average them away; the profile
removes them: the fusion moves each joint by ``-offsets[j]`` in the
body's own axes (x forward, y left, z up, from the hips and neck), and
by ``-depth[j]`` along the line from the view's sensor to the joint (a
depth tracker fits its body model to the surface it sees and places the
joints a few centimetres nearer the sensor than they are, whichever way
the body faces: views from different sides do not share that, in world),
and dates the skeleton ``delay`` s before its stamp. ``delay_spread``
(95 %, s) is the timing uncertainty that dating adds (``timing_spread``:
the part of a view's error along a joint's motion that grows with its
speed); ``sigma`` (m, one axis, at confidence 1) is the error a view has
on its own, growing as ``confidence ** -confidence_power`` (1: as one
over the confidence) and, for the elbows and hands, by ``1 + back_arms *
back_view`` with how much of the body's back the view sees (a tracker
seeing the back mistakes the arms more than its confidences say);
``sigma_common`` (m, one axis) the error left that all views share.
A profile with a ``filter`` (hri_sync.fusion.lag: the tracker's one-euro
filter) re-dates each joint by its own lag first, so that every joint
shows the body ``delay`` s before the capture.
``fit_profile`` measures them from views of a motion with its truth
(bench/fusion_accuracy.py --fit-profile; bench/fit_offsets.py the offsets
to another skeleton's joints, each view's sides put the truth's way
first by ``sides_as_truth``). A profile may also carry an
``errors`` model (hri_sync.fusion.errors: each joint's error from where it
lies, learned; bench/fit_error_model.py): the fusion then weighs the
views' joints against each other by it, at the error model's level above,
and a ``posture`` (hri_sync.fusion.posture: where people's elbows lie given
their shoulders and hands, from motion capture; bench/fit_posture.py): the
fusion then takes each fused elbow with its prior (the posture describes
people, not trackers: with a profile per view, the first view's that has
one).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Callable, Dict, List, Optional, Tuple

import numpy as np

from hri_sync.dance_off.joints import INDEX, NUM_JOINTS
from hri_sync.fusion.arms import turned
from hri_sync.fusion.errors import ErrorModel
from hri_sync.fusion.facing import back_view
from hri_sync.fusion.frames import SensorPose
from hri_sync.fusion.fuse import own_sigma
from hri_sync.fusion.lag import FilterLag, FilterParams
from hri_sync.fusion.posture import Posture
from hri_sync.people.rep155 import body_axes

ARMS = [INDEX[n] for n in ('left_elbow', 'right_elbow', 'left_hand',
                           'right_hand')]
BODY_TURN = turned(np.arange(NUM_JOINTS))   # every left, right exchanged
KEYS = ('delay', 'delay_spread', 'sigma', 'sigma_common',
        'confidence_power', 'back_arms')


@dataclass
class Profile:
    """One tracker's shared errors and error model."""

    delay: float = 0.0
    delay_spread: float = 0.0
    sigma: float = 0.05
    sigma_common: float = 0.0
    confidence_power: float = 1.0
    back_arms: float = 0.0
    offsets: np.ndarray = field(
        default_factory=lambda: np.zeros((NUM_JOINTS, 3)))
    depth: np.ndarray = field(default_factory=lambda: np.zeros(NUM_JOINTS))
    filter: Optional[FilterParams] = None
    errors: Optional[ErrorModel] = None
    posture: Optional[Posture] = None

    def filter_lag(self) -> Optional[FilterLag]:
        """A new track's re-dating by the tracker's filter (None: the
        profile has none; one ``delay`` for every joint)."""
        return None if self.filter is None else FilterLag(self.filter,
                                                          self.delay)

    def place(self, positions: np.ndarray, pose: SensorPose,
              stamp: float, lag: Optional[FilterLag]) -> np.ndarray:
        """A view's Skeleton-frame joints (15, 3) captured at ``stamp`` in
        world through the profile: re-dated by ``lag`` (the view's
        ``filter_lag``, or None), placed by ``pose``, corrected."""
        if lag is not None:
            positions = lag.redate(stamp, positions)
        return self.correct(pose.to_world(positions), pose.translation())

    def correct(self, positions: np.ndarray,
                sensor: Optional[np.ndarray] = None) -> np.ndarray:
        """World joints (15, 3) with the depth offsets removed along the
        lines from ``sensor`` (world; None: not), then the body-axes offsets
        (not when the hips or neck are missing)."""
        if sensor is not None and self.depth.any():
            positions = positions - self.depth[:, None] * rays(positions,
                                                              sensor)
        axes = body_axes(positions)
        if axes is None or not self.offsets.any():
            return positions
        return positions - self.offsets @ axes.T

    def vantage(self, back: Optional[float]) -> Optional[np.ndarray]:
        """(15,) multipliers of a view's sigma from where its sensor
        stands to the (fused) body, ``back`` (its ``back_view``; None:
        unknown): the arms' ``1 + back_arms * back``; None when they are
        all 1."""
        if self.back_arms <= 0 or back is None:
            return None
        scale = np.ones(NUM_JOINTS)
        scale[ARMS] += self.back_arms * back
        return scale

    def to_dict(self) -> Dict[str, Any]:
        """Plain values (a YAML param)."""
        out = {'delay': round(self.delay, 4),
                'delay_spread': round(self.delay_spread, 4),
                'sigma': round(self.sigma, 4),
                'sigma_common': round(self.sigma_common, 4),
                'confidence_power': round(self.confidence_power, 3),
                'back_arms': round(self.back_arms, 3),
                'offsets': np.round(self.offsets, 4).tolist(),
                'depth': np.round(self.depth, 4).tolist()}
        if self.filter is not None:
            out['filter'] = self.filter.to_dict()
        if self.errors is not None:
            out['errors'] = self.errors.to_dict()
        if self.posture is not None:
            out['posture'] = self.posture.to_dict()
        return out

    @classmethod
    def from_dict(cls, d: Optional[Dict[str, Any]]) -> 'Profile':
        """A Profile from ``to_dict``'s values (missing keys: defaults)."""
        d = dict(d or {})
        offsets = np.array(d.pop('offsets', np.zeros((NUM_JOINTS, 3))),
                           float)
        if offsets.shape != (NUM_JOINTS, 3) or \
                not np.isfinite(offsets).all():
            raise ValueError('a profile has 15 finite (x, y, z) offsets')
        depth = np.array(d.pop('depth', np.zeros(NUM_JOINTS)), float)
        if depth.shape != (NUM_JOINTS,) or not np.isfinite(depth).all():
            raise ValueError('a profile has 15 finite depth offsets')
        filtered = d.pop('filter', None)
        errors = d.pop('errors', None)
        posture = d.pop('posture', None)
        unknown = set(d) - set(KEYS)
        if unknown:
            raise ValueError('unknown profile keys: %s' % sorted(unknown))
        values = {k: float(v) for k, v in d.items()}
        if not all(np.isfinite(v) and v >= 0 for v in values.values()):
            raise ValueError('profile values are finite and >= 0: %r' % d)
        return cls(offsets=offsets, depth=depth, filter=None if filtered
                   is None else FilterParams.from_dict(filtered),
                   errors=None if errors is None
                   else ErrorModel.from_dict(errors),
                   posture=None if posture is None
                   else Posture.from_dict(posture), **values)


def rays(positions: np.ndarray, sensor: np.ndarray) -> np.ndarray:
    """Unit vectors from ``sensor`` to each of ``positions`` (..., 3)."""
    d = positions - np.asarray(sensor, float)
    return d / np.maximum(np.linalg.norm(d, axis=-1, keepdims=True), 1e-9)


def body_frame_errors(estimates: np.ndarray, truth: np.ndarray
                      ) -> np.ndarray:
    """(views, frames, 15, 3) errors in each estimate's body axes; NaN
    where an estimate has no axes. ``estimates``: (views, frames, 15, 3),
    ``truth``: (frames, 15, 3), world."""
    out = np.full(estimates.shape, np.nan)
    for v in range(estimates.shape[0]):
        for k in range(estimates.shape[1]):
            axes = body_axes(estimates[v, k])
            if axes is not None:
                out[v, k] = (estimates[v, k] - truth[k]) @ axes
    return out


def sides_as_truth(estimates: np.ndarray, truth: np.ndarray,
                   confidence: Optional[np.ndarray] = None
                   ) -> Tuple[np.ndarray, Optional[np.ndarray], int]:
    """``estimates`` (views, frames, 15, 3; world) with each view's left
    and right joints exchanged at the frames where that brings them
    nearer ``truth`` (frames, 15, 3) on the mean, ``confidence`` (views,
    frames, 15) exchanged with them, and how many view-frames were: a
    view that took the back for the front then has its offsets measured
    on the joints it meant, not half way to the other side."""
    out = np.array(estimates, float)
    conf = None if confidence is None else np.array(confidence, float)
    kept = np.linalg.norm(out - truth, axis=-1).mean(axis=-1)
    swapped = np.linalg.norm(out[:, :, BODY_TURN] - truth,
                             axis=-1).mean(axis=-1)
    exchange = swapped < kept
    out[exchange] = out[exchange][:, BODY_TURN]
    if conf is not None:
        conf[exchange] = conf[exchange][:, BODY_TURN]
    return out, conf, int(exchange.sum())


def fit_profile(estimates: np.ndarray, truth: np.ndarray, delay: float,
                delay_spread: float, confidence: Optional[np.ndarray] = None,
                sensors: Optional[np.ndarray] = None,
                centre: Callable[..., np.ndarray] = np.nanmean) -> Profile:
    """The offsets and error model of views of one tracker (frames where
    every view tracks), given its delay (estimates already at it);
    ``confidence`` (views, frames, 15): the confidence power too, and with
    ``sensors`` (views, 3; world) the depth offsets (first) and the arms'
    growth from behind. Each joint's offsets are the ``centre`` of its
    errors over the view-frames (np.nanmedian: a view's gross misses, a
    hand it cannot see, weigh no more than any other)."""
    depth = np.zeros(NUM_JOINTS)
    if sensors is not None:
        ray = np.array([rays(e, s) for e, s in zip(estimates, sensors)])
        along = ((estimates - truth) * ray).sum(axis=-1)
        depth = centre(along.reshape(-1, NUM_JOINTS), axis=0)
        estimates = estimates - depth[:, None] * ray
    err = body_frame_errors(estimates, truth)
    ok = np.isfinite(err).all(axis=(0, 2, 3))
    err = err[:, ok]
    offsets = centre(err, axis=(0, 1))
    rest = err - offsets
    common = rest.mean(axis=0)
    n = rest.shape[0]
    own = rest - common
    sigma = float(np.sqrt((own ** 2).mean() * n / max(n - 1, 1)))
    sigma_common = float(np.sqrt(max((common ** 2).mean()
                                     - sigma ** 2 / n, 0.0)))
    power = 1.0 if confidence is None else \
        confidence_power(own, confidence[:, ok])
    back = 0.0 if confidence is None or sensors is None else back_growth(
        np.linalg.norm(own, axis=-1)
        / own_sigma(sigma, confidence[:, ok], power), truth[ok], sensors)
    return Profile(delay, delay_spread, sigma, sigma_common, power, back,
                   offsets, depth)


def back_growth(norm: np.ndarray, truth: np.ndarray, sensors: np.ndarray,
                bins: int = 5, least: int = 30) -> float:
    """b in the arms' rms error ~ 1 + b * back_view: a line through the
    rms of ``norm`` (views, frames, 15: each error over its modelled
    sigma) on the elbows and hands in ``bins`` equal steps of the views'
    back_view (each with ``least`` errors or more) over its value at 0;
    0 when the line does not rise. ``truth``: (frames, 15, 3), world;
    ``sensors``: (views, 3)."""
    xs: List[float] = []
    es: List[float] = []
    for v, sensor in enumerate(sensors):
        for k, body in enumerate(truth):
            back = back_view(body, sensor)
            if back is not None:
                xs.extend([back] * len(ARMS))
                es.extend(norm[v, k, ARMS])
    x, e = np.array(xs), np.array(es)
    ok = np.isfinite(e)
    x, e = x[ok], e[ok]
    step = np.minimum((x * bins).astype(int), bins - 1)
    points = [(x[step == b].mean(), np.sqrt((e[step == b] ** 2).mean()))
              for b in range(bins) if (step == b).sum() >= least]
    if len(points) < 2:
        return 0.0
    px, py = np.array(points).T
    slope, at_zero = np.polyfit(px, py, 1)
    return float(max(slope / at_zero, 0.0)) if at_zero > 0 else 0.0


def timing_spread(errors: np.ndarray, velocity: np.ndarray) -> float:
    """The 95 % bound (s) of the part of the views' errors along each
    joint's motion that grows with its speed, as a time: ``1.96 *
    sqrt(b)`` in ``along ** 2 = a + b * speed ** 2`` (least squares).
    ``errors``: (views, frames, 15, 3), ``velocity``: (frames, 15, 3),
    world, the truth's."""
    speed = np.linalg.norm(velocity, axis=-1)
    along = (errors * velocity).sum(axis=-1) / np.maximum(speed, 1e-9)
    speed = np.broadcast_to(speed, along.shape)
    ok = np.isfinite(along) & (speed > 0)
    x, y = speed[ok] ** 2, along[ok] ** 2
    b = np.linalg.lstsq(np.vstack([np.ones_like(x), x]).T, y,
                        rcond=None)[0][1]
    return float(1.96 * np.sqrt(max(b, 0.0)))


def confidence_power(own: np.ndarray, confidence: np.ndarray,
                     least: int = 30) -> float:
    """p in rms error ~ confidence ** -p: the slope of log rms error on
    log confidence within each joint (its confidence levels with
    ``least`` errors or more), pooled over joints. ``own``: (views,
    frames, 15, 3) errors, ``confidence``: (views, frames, 15)."""
    norms = np.linalg.norm(own, axis=-1)
    xs, ys = [], []
    for j in range(norms.shape[2]):
        c, e = np.round(confidence[..., j], 2).ravel(), norms[..., j].ravel()
        levels = [(np.log(v), np.log(np.sqrt(np.mean(e[c == v] ** 2))))
                  for v in np.unique(c) if v > 0 and (c == v).sum() >= least]
        if len(levels) > 1:
            x, y = np.array(levels).T
            xs.append(x - x.mean())
            ys.append(y - y.mean())
    if not xs:
        return 1.0
    x, y = np.concatenate(xs), np.concatenate(ys)
    return float(-(x * y).sum() / (x * x).sum())


def profiles(values: Dict[str, Any], views: List[str]) -> Dict[str, Profile]:
    """Each view's Profile from a param: one profile dict for all views,
    or {view: profile dict}."""
    if values and all(v in views for v in values):
        return {v: Profile.from_dict(values.get(v)) for v in views}
    one = Profile.from_dict(values)
    return {v: one for v in views}
