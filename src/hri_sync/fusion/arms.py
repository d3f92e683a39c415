"""A view whose tracker exchanged the arms, or took the body's back for
its front: told, and put right.

A depth tracker that sees a body from behind or side-on often fits its
left arm to the right arm's points and the other way round: the view's
arms cross where the body's do not (the project's tracker in 10-27 % of
the frames of a view from behind). Left in, such a view pulls each fused
hand towards the other one. Before a person is fused, each of its views'
arms (elbows and hands, with their confidences) is exchanged when two
references both say the exchanged labels fit better, by at least
``margin`` m summed over the four joints: the person's body predicted
from its last two fused instants (constant velocity), and the body fused
at this instant from the person's other views (three or more: two
views often exchange the arms together).
Either reference alone goes wrong: the prediction follows a fused body
that once took the wrong labels and keeps them, and the other views
often exchange the arms at the same instants. Only a minority of the
views is ever exchanged: where half of them would be, the fused body's
own labels are in doubt, and the trackers' stand.

A tracker that takes the body's back for its front (it fits a body
facing its sensor until the knees say otherwise) exchanges every left
and right joint, shoulders, hips and legs too: such a view is turned
back (all twelve exchanged) the same way, by at least ``turn_margin`` m
summed over them and ``trunk_margin`` m over the shoulders and hips
alone (which every view sees; a view whose arms alone are exchanged
gains on the twelve but loses on the trunk), against two or more other
views, before its arms are judged.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import List, Optional, Sequence, Tuple

import numpy as np

from hri_sync.dance_off.joints import INDEX
from hri_sync.fusion.fuse import FuseParams, Observation, fuse

LEFT = [INDEX['left_elbow'], INDEX['left_hand']]
RIGHT = [INDEX['right_elbow'], INDEX['right_hand']]
SIDES = ('shoulder', 'elbow', 'hand', 'hip', 'knee', 'foot')
BODY_LEFT = [INDEX['left_' + s] for s in SIDES]
BODY_RIGHT = [INDEX['right_' + s] for s in SIDES]
TRUNK = [INDEX[j] for j in ('left_shoulder', 'right_shoulder', 'left_hip',
                            'right_hip')]


@dataclass
class ArmParams:
    """When a view's arms are exchanged, or its body turned."""

    margin: float = 0.2         # m, summed over the four arm joints
    min_others: int = 3         # other views of the person at the instant
    turn_margin: float = 0.6    # m, summed over the twelve side joints
    trunk_margin: float = 0.3   # m, over the shoulders and hips
    turn_min_others: int = 2


def exchanged(positions: np.ndarray, left: Sequence[int] = LEFT,
              right: Sequence[int] = RIGHT) -> np.ndarray:
    """A copy of (15, ...) ``positions`` (or confidences) with the joints
    ``left`` and ``right`` exchanged (the elbows and hands by default)."""
    out = np.array(positions, copy=True)
    out[list(left)], out[list(right)] = positions[right], positions[left]
    return out


def turned(positions: np.ndarray) -> np.ndarray:
    """A copy of (15, ...) ``positions`` (or confidences) with every left
    and right joint exchanged."""
    return exchanged(positions, BODY_LEFT, BODY_RIGHT)


def _gain(positions: np.ndarray, reference: np.ndarray,
          left: Sequence[int], right: Sequence[int],
          joints: Sequence[int]) -> float:
    """How much nearer ``reference`` the ``joints`` come with ``left`` and
    ``right`` exchanged (m, summed over the joints both give)."""
    kept = np.linalg.norm(positions[joints] - reference[joints], axis=1)
    swapped = np.linalg.norm(exchanged(positions, left, right)[joints]
                             - reference[joints], axis=1)
    ok = np.isfinite(kept) & np.isfinite(swapped)
    return float(kept[ok].sum() - swapped[ok].sum())


Test = Tuple[Sequence[int], float]     # joints, the margin they must gain


def _to_exchange(views: List[Observation], predicted: Optional[np.ndarray],
                 left: Sequence[int], right: Sequence[int],
                 tests: Sequence[Test], min_others: int,
                 fuse_params: FuseParams) -> List[bool]:
    """For each view, whether both the ``predicted`` body and the body
    fused from the other views prefer its joints ``left`` and ``right``
    exchanged, by each test's margin over its joints; none without a
    prediction, with fewer than ``min_others`` other views, or where half
    the views or more would be."""
    if predicted is None or len(views) < min_others + 1:
        return [False] * len(views)

    def prefer(view: Observation, reference: np.ndarray) -> bool:
        return all(_gain(view.positions, reference, left, right, joints)
                   >= margin for joints, margin in tests)
    out = []
    for i, view in enumerate(views):
        out.append(prefer(view, predicted) and prefer(view, fuse(
            [v for k, v in enumerate(views) if k != i],
            fuse_params).positions))
    if 2 * sum(out) >= len(out):
        return [False] * len(views)     # no majority to put them right
    return out


def arms_to_exchange(views: List[Observation],
                     predicted: Optional[np.ndarray],
                     params: ArmParams,
                     fuse_params: FuseParams) -> List[bool]:
    """For each of one person's ``views``, whether its arms are exchanged
    (``predicted``: the body, (15, 3), None: no prediction)."""
    return _to_exchange(views, predicted, LEFT, RIGHT,
                        [(LEFT + RIGHT, params.margin)], params.min_others,
                        fuse_params)


def bodies_to_turn(views: List[Observation],
                   predicted: Optional[np.ndarray],
                   params: ArmParams,
                   fuse_params: FuseParams) -> List[bool]:
    """For each of one person's ``views``, whether its tracker took the
    body's back for its front (every left and right joint exchanged)."""
    return _to_exchange(views, predicted, BODY_LEFT, BODY_RIGHT,
                        [(BODY_LEFT + BODY_RIGHT, params.turn_margin),
                         (TRUNK, params.trunk_margin)],
                        params.turn_min_others, fuse_params)
