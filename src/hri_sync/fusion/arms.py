"""A view whose tracker exchanged the arms: told, and put right.

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
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import List, Optional

import numpy as np

from hri_sync.dance_off.joints import INDEX
from hri_sync.fusion.fuse import FuseParams, Observation, fuse
from hri_sync.fusion.profile import ARMS

LEFT = [INDEX['left_elbow'], INDEX['left_hand']]
RIGHT = [INDEX['right_elbow'], INDEX['right_hand']]


@dataclass
class ArmParams:
    """When a view's arms are exchanged."""

    margin: float = 0.2         # m, summed over the four arm joints
    min_others: int = 3         # other views of the person at the instant


def exchanged(positions: np.ndarray) -> np.ndarray:
    """A copy of (15, ...) ``positions`` (or confidences) with the left
    and right elbows and hands exchanged."""
    out = np.array(positions, copy=True)
    out[LEFT], out[RIGHT] = positions[RIGHT], positions[LEFT]
    return out


def _gain(positions: np.ndarray, reference: np.ndarray) -> float:
    """How much nearer ``reference`` the arms come exchanged (m, summed
    over the arm joints both give)."""
    kept = np.linalg.norm(positions[ARMS] - reference[ARMS], axis=1)
    swapped = np.linalg.norm(exchanged(positions)[ARMS] - reference[ARMS],
                             axis=1)
    ok = np.isfinite(kept) & np.isfinite(swapped)
    return float(kept[ok].sum() - swapped[ok].sum())


def arms_to_exchange(views: List[Observation],
                     predicted: Optional[np.ndarray],
                     params: ArmParams,
                     fuse_params: FuseParams) -> List[bool]:
    """For each of one person's ``views``, whether its arms are exchanged:
    both the ``predicted`` body (15, 3; None: no prediction) and the body
    fused from the other views prefer the exchanged labels by
    ``params.margin``. Nothing is exchanged without a prediction, with
    fewer than ``params.min_others`` other views, or where half the views
    or more would be."""
    if predicted is None or len(views) < params.min_others + 1:
        return [False] * len(views)
    out = []
    for i, view in enumerate(views):
        if _gain(view.positions, predicted) < params.margin:
            out.append(False)
            continue
        others = fuse([v for k, v in enumerate(views) if k != i],
                      fuse_params).positions
        out.append(_gain(view.positions, others) >= params.margin)
    if 2 * sum(out) >= len(out):
        return [False] * len(views)     # no majority to put them right
    return out
