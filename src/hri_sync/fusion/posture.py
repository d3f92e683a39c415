"""Where a person's elbows lie, given the shoulders and hands.

An elbow the body hides from every view is each tracker's guess, and the
guesses agree on little (docs/fusion.md). The shoulder and the hand leave
the elbow one way to turn, and people hold their arms alike: a
``Posture`` keeps, from motion capture, each arm's hand and elbow in the
shoulders' axes (the right arm as it is, the left mirrored onto it), and
gives a fused elbow's prior as the mean of the elbows whose hands lay
nearest its hand (``neighbours`` of them, each weighed by one over its
hand's distance plus 2 cm). The prior's error (m, one axis) is ``sigma``
with the spread of those elbows and half the hands' mean distance (an
elbow moves about half as far as its hand). The fusion takes a fused
elbow and its prior at their inverse variances
(hri_sync.fusion.pipeline). A pose unlike any the capture holds has a
prior whose neighbours' hands lie far, which weighs little. Where the
fused elbow and the prior lie ``z`` times their joint spread apart (3-D),
``z`` beyond ``gate``, the prior's variance grows by ``exp((z^2 -
gate^2) / 2)``, as their agreement's likelihood falls: an elbow the views
see well in a pose the capture never had (a hand at the shoulder, its
elbow down where the capture's were raised) stays nearly where they put
it.

The shoulders' axes: x from the left shoulder to the right, y up (the
torso to the neck, square to x), z = x cross y. ``fit_posture`` builds one
from world joints (bench/fit_posture.py).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Dict, Optional, Tuple

import numpy as np

from hri_sync.dance_off.joints import INDEX

# each arm's shoulder, elbow and hand, and its mirror onto the right arm
ARMS: Tuple[Tuple[str, str, str, float], ...] = (
    ('left_shoulder', 'left_elbow', 'left_hand', -1.0),
    ('right_shoulder', 'right_elbow', 'right_hand', 1.0))
NEAR = 0.02     # m added to each neighbour's hand distance (its weight)


def shoulder_axes(positions: np.ndarray) -> Optional[np.ndarray]:
    """(3, 3) rows x, y, z of the shoulders' axes in world, from world
    joints (15, 3); None when the shoulders, neck or torso are missing or
    fall on one line."""
    across = positions[INDEX['right_shoulder']] \
        - positions[INDEX['left_shoulder']]
    up = positions[INDEX['neck']] - positions[INDEX['torso']]
    width = np.linalg.norm(across)
    if not np.isfinite(width) or width < 1e-6 \
            or not np.isfinite(up).all():
        return None
    x = across / width
    y = up - (up @ x) * x
    height = np.linalg.norm(y)
    if height < 1e-6:
        return None
    y = y / height
    return np.stack([x, y, np.cross(x, y)])


def _in_axes(joints: np.ndarray, axes: np.ndarray) -> np.ndarray:
    """(2, 2, 3) each arm's (hand, elbow) from its shoulder in ``axes``,
    the left mirrored, from world joints (15, 3)."""
    return np.array([[axes @ (joints[INDEX[joint]] - joints[INDEX[shoulder]])
                      * (mirror, 1.0, 1.0) for joint in (hand, elbow)]
                     for shoulder, elbow, hand, mirror in ARMS])


def arms_in_axes(positions: np.ndarray) -> np.ndarray:
    """(frames, 2, 2, 3) each arm's (hand, elbow) from its shoulder in the
    shoulders' axes, the left mirrored; NaN where a joint is missing.
    ``positions``: (frames, 15, 3) world."""
    out = np.full((len(positions), 2, 2, 3), np.nan)
    for f, joints in enumerate(positions):
        axes = shoulder_axes(joints)
        if axes is not None:
            out[f] = _in_axes(joints, axes)
    return out


@dataclass
class Posture:
    """Hands and elbows from motion capture: a hidden elbow's prior."""

    hands: np.ndarray           # (n, 3) m, from the shoulder, its axes
    elbows: np.ndarray          # (n, 3) m, the same arms' elbows
    sigma: float = 0.03         # m, one axis, at the capture's own poses
    neighbours: int = 8
    gate: float = 2.5           # joint spreads: beyond, the prior yields

    def __post_init__(self) -> None:
        self.hands = np.asarray(self.hands, float)
        self.elbows = np.asarray(self.elbows, float)
        if self.hands.ndim != 2 or self.hands.shape[1] != 3 \
                or self.elbows.shape != self.hands.shape \
                or len(self.hands) < self.neighbours \
                or not np.isfinite(self.hands).all() \
                or not np.isfinite(self.elbows).all():
            raise ValueError('a posture has at least %d finite (x, y, z) '
                             'hands and as many elbows' % self.neighbours)
        if not (np.isfinite(self.sigma) and self.sigma > 0
                and self.gate > 0):
            raise ValueError('a posture sigma is > 0 m and its gate > 0: '
                             '%r, %r' % (self.sigma, self.gate))

    def prior(self, hand: np.ndarray) -> Tuple[np.ndarray, float]:
        """An elbow (3,) and its variance (m^2, one axis) from a hand
        (3,), both from the shoulder in its axes (mirrored: the right
        arm's)."""
        distance = np.linalg.norm(self.hands - hand, axis=1)
        near = np.argpartition(distance, self.neighbours - 1)[
            :self.neighbours]
        weight = 1.0 / (distance[near] + NEAR)
        weight /= weight.sum()
        elbows = self.elbows[near]
        elbow = weight @ elbows
        spread = weight @ ((elbows - elbow) ** 2).sum(axis=1) / 3.0
        reach = weight @ distance[near]
        return elbow, self.sigma ** 2 + spread + reach ** 2 / 4.0

    def place(self, positions: np.ndarray, sigma: np.ndarray
              ) -> np.ndarray:
        """World joints (15, 3) with each elbow taken with its prior at
        their inverse variances (``sigma``: (15,) m, one axis, the
        positions' error); an elbow, shoulder or hand missing (or the
        shoulders' axes) leaves the arm as it is."""
        axes = shoulder_axes(positions)
        if axes is None:
            return positions
        out = positions.copy()
        for (shoulder, elbow, hand, mirror), (seen, _) in zip(
                ARMS, _in_axes(positions, axes)):
            s, e = INDEX[shoulder], INDEX[elbow]
            if not (np.isfinite(positions[[s, e, INDEX[hand]]]).all()
                    and np.isfinite(sigma[e]) and sigma[e] > 0):
                continue
            mean, var = self.prior(seen)
            guess = positions[s] + axes.T @ (mean * (mirror, 1.0, 1.0))
            own = sigma[e] ** 2
            apart = float(np.linalg.norm(guess - positions[e])) \
                / math.sqrt(3.0 * (var + own))
            var *= math.exp(max(0.0, apart ** 2 - self.gate ** 2) / 2.0)
            out[e] = (positions[e] * var + guess * own) / (var + own)
        return out

    def to_dict(self) -> Dict[str, Any]:
        """Plain values (a YAML param): mm integers."""
        return {'sigma': round(self.sigma, 4),
                'neighbours': self.neighbours, 'gate': self.gate,
                'arms': np.round(np.hstack([self.hands, self.elbows])
                                 * 1000).astype(int).tolist()}

    @classmethod
    def from_dict(cls, d: Dict[str, Any]) -> 'Posture':
        """A Posture from ``to_dict``'s values."""
        d = dict(d)
        arms = np.array(d.pop('arms', []), float) / 1000.0
        if arms.ndim != 2 or arms.shape[1] != 6:
            raise ValueError('a posture has (hand, elbow) rows of six mm '
                             'values')
        sigma = float(d.pop('sigma', cls.sigma))
        neighbours = int(d.pop('neighbours', cls.neighbours))
        gate = float(d.pop('gate', cls.gate))
        if d:
            raise ValueError('unknown posture keys: %s' % sorted(d))
        return cls(arms[:, :3], arms[:, 3:], sigma, neighbours, gate)


def fit_posture(positions: np.ndarray, sigma: float = Posture.sigma
                ) -> Posture:
    """A Posture from motion capture: world joints (frames, 15, 3), both
    arms of every frame whose shoulders, neck, torso, hands and elbows are
    all there."""
    arms = arms_in_axes(positions).reshape(-1, 2, 3)
    whole = np.isfinite(arms).all(axis=(1, 2))
    return Posture(arms[whole, 0], arms[whole, 1], sigma)
