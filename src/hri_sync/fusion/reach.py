"""A hand no arm of the person reaches.

A view that does not see a person's arm (out of its image, or the person
too far) still gives its tracker's guess of the hand, often at some
confidence, and sometimes far from where the arm is: on the walk, the
view 2 m in front places a hand it cannot see 0.8 m off at confidence 0.3
while the view that sees the arm has the elbow right and the hand just
outside its image (confidence 0). Fused, such a guess is the hand. Once a
person is fused, each view's hand farther from the fused elbow than a
forearm and the elbow's error allow (``hand`` m: a forearm to the hand's
centre is 0.22-0.27 m in the motion clips) is not that arm's hand, unless
another view puts that hand within ``agree`` m of it (then the fused
elbow is what is wrong): it is left out, and the person fused again.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import List

import numpy as np

from hri_sync.dance_off.joints import INDEX
from hri_sync.fusion.fuse import LEAST_CONFIDENCE, Observation

ELBOWS = [INDEX['left_elbow'], INDEX['right_elbow']]
HANDS = [INDEX['left_hand'], INDEX['right_hand']]


@dataclass
class ReachParams:
    """How far a hand may be from its fused elbow."""

    hand: float = 0.5           # m
    agree: float = 0.2          # m, another view's hand that keeps it


def _seconded(views: List[Observation], i: int, joint: int,
              params: ReachParams) -> bool:
    """Whether a view other than ``views[i]`` gives ``joint`` within
    ``params.agree`` of where ``views[i]`` has it."""
    here = views[i].positions[joint]
    return any(np.linalg.norm(o.positions[joint] - here) <= params.agree
               for k, o in enumerate(views)
               if k != i and o.confidence[joint] >= LEAST_CONFIDENCE)


def out_of_reach(views: List[Observation], positions: np.ndarray,
                 params: ReachParams) -> List[np.ndarray]:
    """For each of one person's ``views``, a (15,) mask of its hands
    farther than ``params.hand`` from the elbows of the person's fused
    body (``positions``, (15, 3); an elbow it lacks says nothing) that no
    other view seconds."""
    out = []
    for i, view in enumerate(views):
        mask = np.zeros(len(view.positions), bool)
        apart = np.linalg.norm(view.positions[HANDS] - positions[ELBOWS],
                               axis=1)
        for hand, far in zip(HANDS, np.isfinite(apart)
                             & (apart > params.hand)):
            mask[hand] = far and not _seconded(views, i, hand, params)
        out.append(mask)
    return out
