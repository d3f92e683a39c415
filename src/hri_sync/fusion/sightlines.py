"""Two views that should see each other's people and never do.

A view should see a person whose core stands in its field of view
(``fov_deg`` wide less ``margin_deg`` each side, ``near`` to ``far`` m from
it) with no other person in front of them within ``shadow`` m of the line
of sight. Two views that each give people and share none with any view,
while every person one of them gives stands in the other's sight, for
``after`` s, disagree: one of their poses is wrong by more than the
association's gates (they give one person twice), or the other view is
blind there. (One way is enough: a person given twice along one view's
line of sight looks, to that view, like someone hidden behind.) With
three or more views the pipeline fits a wrong pose to the people the
others agree on; with two there is no third to say which pose is wrong,
so the pair is reported (``unmatched``) with the distance between their
people, and ``fusion_refine`` mends it. The check is along the floor: a
sensor's pitch and vertical field are not used.

``outside_image`` is what a view cannot measure of a body: its joints
farther than ``beyond_deg`` outside the sensor's image (``fov_deg`` wide,
``vertical_fov_deg`` high), whatever its tracker says of them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Dict, Iterable, List, Optional, Set, Tuple

import numpy as np

from hri_sync.fusion.associate import CORE, body_distance
from hri_sync.fusion.frames import SensorPose


@dataclass
class SightParams:
    """A view's field along the floor (Kinect v1 by default)."""

    fov_deg: float = 57.0       # horizontal field of view
    margin_deg: float = 4.0     # kept inside each edge
    near: float = 0.8           # m
    far: float = 4.5            # m
    range: float = 5.0          # m the sensor reads depth to
    shadow: float = 0.35        # m each side of a line of sight
    after: float = 3.0          # s the disagreement lasts before a report
    vertical_fov_deg: float = 43.0  # the image's height
    beyond_deg: float = 5.0     # outside an image's edge: not measured


def place(body: np.ndarray) -> Optional[np.ndarray]:
    """(x, y) of a body's core joints (all joints without them), or None
    when it has no finite joint."""
    for rows in (body[CORE], body):
        xy = rows[:, :2][np.isfinite(rows[:, :2]).all(axis=1)]
        if len(xy):
            return np.median(xy, axis=0)
    return None


def distance(body: np.ndarray, sensor: np.ndarray) -> float:
    """How far (m, along the floor) a body (15, 3) stands (``place``) from
    a sensor (3,); NaN when it has no finite joint."""
    xy = place(body)
    return math.nan if xy is None else math.hypot(
        *(xy - np.asarray(sensor, float)[:2]))


def in_sight(pose: SensorPose, point: np.ndarray,
             others: Iterable[np.ndarray], params: SightParams) -> bool:
    """Whether ``point`` (world x, y) is in ``pose``'s field and no point
    of ``others`` stands in front of it on its line of sight."""
    d = point - np.array([pose.x, pose.y])
    r = float(np.hypot(*d))
    bearing = math.atan2(d[1], d[0]) - pose.yaw
    bearing = math.atan2(math.sin(bearing), math.cos(bearing))
    if not (params.near <= r <= params.far and abs(bearing) <= math.radians(
            params.fov_deg / 2.0 - params.margin_deg)):
        return False
    u = d / r
    for q in others:
        e = q - np.array([pose.x, pose.y])
        along = float(e @ u)
        if 0.0 < along < r and abs(e[0] * u[1] - e[1] * u[0]) < params.shadow:
            return False
    return True


def outside_image(pose: SensorPose, positions: np.ndarray,
                  params: SightParams) -> np.ndarray:
    """(15,) mask of the world ``positions`` (15, 3) farther than
    ``beyond_deg`` outside ``pose``'s image (False where not finite)."""
    local = pose.from_world(positions)
    ahead = np.where(local[:, 2] > 0, local[:, 2], np.nan)
    across = np.degrees(np.arctan2(np.abs(local[:, 0]), ahead))
    up = np.degrees(np.arctan2(np.abs(local[:, 1]), ahead))
    with np.errstate(invalid='ignore'):
        out = (across > params.fov_deg / 2.0 + params.beyond_deg) \
            | (up > params.vertical_fov_deg / 2.0 + params.beyond_deg) \
            | (local[:, 2] <= 0)
    return out & np.isfinite(local).all(axis=1)


class Sightlines:
    """Which pairs of views disagree, instant by instant."""

    def __init__(self, params: Optional[SightParams] = None) -> None:
        self.params = params or SightParams()
        # pair: (since when, m between their people now)
        self.pairs: Dict[Tuple[str, str], Tuple[float, float]] = {}
        self.t = -math.inf                              # the last instant
        self.instants: Dict[str, int] = {}  # view: instants reported

    def update(self, t: float, people: Dict[int, Tuple[np.ndarray,
                                                       Set[str]]],
               poses: Dict[str, SensorPose]) -> None:
        """The fused people at instant ``t``: {person: (world joints, the
        views that gave them)}."""
        places = {p: place(body) for p, (body, _) in people.items()}
        given: Dict[str, List[int]] = {}
        for p, (_, views) in people.items():
            for v in views:
                given.setdefault(v, []).append(p)
        alone = sorted(v for v in given if all(
            len(people[p][1]) == 1 for p in given[v]))
        now: Dict[Tuple[str, str], float] = {}
        for a in alone:
            for b in alone:
                if a < b and (self._unseen(a, b, given, people, places,
                                           poses)
                              or self._unseen(b, a, given, people, places,
                                              poses)):
                    now[(a, b)] = min(
                        body_distance(people[p][0], people[q][0])
                        for p in given[a] for q in given[b])
        self.pairs = {pair: (self.pairs.get(pair, (t, 0.0))[0], m)
                      for pair, m in now.items()}
        self.t = t
        for view in self.disagreeing():
            self.instants[view] = self.instants.get(view, 0) + 1

    def _unseen(self, a: str, b: str, given: Dict[str, List[int]],
                people: Dict[int, Tuple[np.ndarray, Set[str]]],
                places: Dict[int, Optional[np.ndarray]],
                poses: Dict[str, SensorPose]) -> bool:
        """Every person of view ``a`` is in ``b``'s sight and not ``b``'s."""
        for p in given[a]:
            here = places[p]
            if b in people[p][1] or here is None:
                return False
            others = [x for q, x in places.items() if q != p and x is not None]
            if not in_sight(poses[b], here, others, self.params):
                return False
        return True

    def disagreeing(self) -> Dict[str, List[Tuple[str, float]]]:
        """{view: [(other view, m between their people)]} of the pairs
        that have disagreed for ``after`` s by the last instant."""
        out: Dict[str, List[Tuple[str, float]]] = {}
        for (a, b), (since, m) in sorted(self.pairs.items()):
            if self.t - since >= self.params.after:
                out.setdefault(a, []).append((b, m))
                out.setdefault(b, []).append((a, m))
        return out
