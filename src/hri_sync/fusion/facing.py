"""Which way a person faces, where the views disagree: the side the
hands reach to.

A depth tracker with no cue to the body's front (the project's reads it
from bent knees) fits a body facing its sensor: every view behind a
person who faces another sensor takes the back for the front. Where such
views outnumber the ones in front, the turn rule of
hri_sync.fusion.arms, which puts right a minority against the others,
cannot. People reach in front of their trunk (a shoulder flexes to
about 180 degrees and extends to about 50), and the hands' places do not
depend on which arm a view calls left: where the views' fronts (from
their labelled hips and neck; none from hips under ``HIPS_APART``
apart) point opposite ways (some more than ``split`` along the views'
common axis, some less than -``split``), the hands the views see (confidence
``confidence`` or more), from each view's trunk centre, are averaged
along that axis, weighted by confidence, where ``views`` views or more
see one (a far view's lone hand can be 0.7 m off at full confidence).
When they lie ``margin`` m or more to one side, and no hand a view sees
lies ``margin`` or more to the other (one hand punching, the other drawn
back behind the trunk: the average then points either way), that side is
the front, and every view whose front points the other way is turned
(every left and right joint exchanged).
Nearer the trunk (arms hanging, hands on the hips) the hands say
nothing, and the front they last decided (``HeldFront``), turned since
with the fused body (a dancer spins within a second), decides in their
stead for ``hold`` s after they last confirmed it (decided it at
``confirm`` instants within ``confirm_within`` s: one instant can be a
tracker's slip; hands that say the other side from a held front decide
only so confirmed, and said at more instants of that time than the held
front: a kick swings both arms behind the trunk for a few instants after
they punched forwards); otherwise the head decides, its labels in doubt: a
person's head leads the trunk's line (from the hips' centre through the
neck, extended by the neck-head length) to the front, on Kinect SDK
skeletons of real people by 0.05-0.10 m (medians of five subjects; the
views' trackers measure the least's mostly under 0.05 m); where the
views that see the head, neck and hips lead it
``split_head_margin`` or more to one side on average, weighted by
confidence, the views facing the other way are turned. These are
centre joints, the same whichever arm a view calls left. A
motion-capture head on the skull's axis leads by about 0.03 m, or lags
(a walker's first second: 0.03 m behind), hence a margin. Where the
head does not decide either, the views stand here, and the turn rule of
hri_sync.fusion.arms then follows their majority, which is as often the
views behind: so the margin is smaller where the views disagree than
where they agree (``head_margin``, below). Only the hands at the
instant make the labels sure: where a held front or the head decides,
or nothing does, they are in doubt (a held front was wrong in 0-55 %
of the instants it decided on real recordings of kicking and punching),
and so are the labels of views
that all agree on a front their head leads away from by ``head_margin``
(every view, the one in front too, can take the back for the front for
seconds). Where those views' legs are straight (no knee ``knee_bend``
off its hip-foot line, median over the views; the project's tracker
reads the front from knees bent 0.15 m), their trackers had no cue to
the front, and they are turned to the head. Labels in doubt: each left
and right joint's bound takes in its partner on the other side
(``either_side``). Turned with the body, a held front does not grow
stale as the person turns; what ``hold`` bounds is how long a wrong one
lasts.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import List, Optional, Tuple

import numpy as np

from hri_sync.dance_off.joints import INDEX
from hri_sync.fusion.arms import TRUNK, turned
from hri_sync.fusion.fuse import Observation
from hri_sync.people.rep155 import body_axes

HANDS = [INDEX['left_hand'], INDEX['right_hand']]
HEAD, NECK = INDEX['head'], INDEX['neck']
HIPS = [INDEX['left_hip'], INDEX['right_hip']]
LEGS = [[INDEX[side + joint] for joint in ('_hip', '_knee', '_foot')]
        for side in ('left', 'right')]
CENTRE = [HEAD, NECK] + HIPS    # the head's lead: the same either way
HIPS_APART = 0.1    # m; people's hip joints lie 0.2-0.3 m apart


@dataclass
class FacingParams:
    """When the hands, a held front or the head decide which way a person
    faces."""

    margin: float = 0.1         # m the hands lie in front of the trunk
    confidence: float = 0.5     # a view's hand it sees
    views: int = 2              # views that see a hand
    split: float = 0.3          # cosine of a front from the views' axis
    hold: float = 10.0          # s the hands' last front decides for them
    confirm: int = 2            # instants that confirm a front ...
    confirm_within: float = 1.0  # ... within this long (s)
    head_margin: float = 0.05   # m the head leads the trunk's line
    split_head_margin: float = 0.03  # ... where the views disagree
    knee_bend: float = 0.15     # m a knee bends off its hip-foot line


def front(positions: np.ndarray, hips_apart: float = HIPS_APART
          ) -> Optional[np.ndarray]:
    """The horizontal unit vector a body at ``positions`` (world, z up)
    faces as its labels say (from its hips and neck); None when those
    are not given, the hips lie under ``hips_apart`` apart (no side to
    tell) or the body lies flat."""
    hips = positions[INDEX['left_hip']] - positions[INDEX['right_hip']]
    if not np.linalg.norm(hips) >= hips_apart:
        return None
    axes = body_axes(positions)
    if axes is None:
        return None
    forward = np.array([axes[0, 0], axes[1, 0], 0.0])
    norm = np.linalg.norm(forward)
    return forward / norm if norm > 1e-6 else None


def back_view(positions: np.ndarray, sensor: np.ndarray
              ) -> Optional[float]:
    """How much of a body's back a sensor sees: ``(1 - cos a) / 2``, a
    the angle at the body between its front and the sensor along the floor
    (0 front-on, 0.5 side-on, 1 from behind); None when the body has no
    axes (hips or neck missing). World (z up) positions (15, 3) and
    sensor position."""
    return back_views(positions, [sensor])[0]


def back_views(positions: np.ndarray, sensors: List[np.ndarray]
               ) -> List[Optional[float]]:
    """``back_view`` of one body for each of ``sensors``, its front found
    once."""
    faces = front(positions, hips_apart=0.0)
    out: List[Optional[float]] = []
    for sensor in sensors:
        to = np.asarray(sensor, float)[:2] - positions[INDEX['torso'], :2]
        norm = np.linalg.norm(to)
        out.append(None if faces is None or not np.isfinite(norm)
                   or norm < 1e-9
                   else float((1.0 - faces[:2] @ to / norm) / 2.0))
    return out


@dataclass
class Decision:
    """What the hands, a held front or the head say of one person's views
    at an instant."""

    turn: List[bool]                    # per view: turn it
    front: Optional[np.ndarray] = None  # the front the hands decided
    unsure: bool = False                # the views disagree, in doubt
    by_head: bool = False               # the head's lead turned the views
    against: Optional[np.ndarray] = None  # the hands' front, held off


def views_to_turn(views: List[Observation], params: FacingParams,
                  held: Optional[np.ndarray] = None,
                  overrule: bool = True) -> Decision:
    """For each of one person's ``views``, whether its front points away
    from the side the person's hands reach to, where the views disagree
    on the front; and that front (horizontal unit vector), None where the
    hands do not decide. There, ``held`` (the front the hands last
    decided, confirmed within ``params.hold``) decides in their stead;
    without it the head's lead may (``by_head``), the views' labels in
    doubt either way (``unsure``); views that agree are in doubt where
    their head leads the other way, and turned to it on straight legs.
    Unless ``overrule``, hands that say the other side from ``held``
    decide nothing (their front is given as ``against``)."""
    fronts = [front(o.positions) for o in views]
    known = [f for f in fronts if f is not None]
    if len(known) < 2:
        return Decision([False] * len(views))
    # The line the fronts lie along, whichever way each points.
    _, vectors = np.linalg.eigh(sum(np.outer(f, f) for f in known))
    axis = vectors[:, -1]
    along = np.array([f @ axis if f is not None else 0.0 for f in fronts])
    if not (along.max() > params.split and along.min() < -params.split):
        agreed = float(np.sign(along.sum()))
        head = _head_side(views, axis, params, params.head_margin)
        if agreed * head >= 0:
            return Decision([False] * len(views))
        turn = _knees_straight(views, params)
        return Decision([turn and bool(a * head < -params.split)
                         for a in along], unsure=True, by_head=turn)
    side = _side(_hands(views, axis, params), params)
    against = None
    if side and not overrule and held is not None \
            and side * float(held @ axis) < -params.split:
        side, against = 0.0, side * axis
    if side:
        return Decision([bool(a * side < -params.split) for a in along],
                        side * axis)
    by_head = False
    if held is not None and abs(held @ axis) > params.split:
        side = float(np.sign(held @ axis))
    else:
        side = _head_side(views, axis, params, params.split_head_margin)
        by_head = bool(side)
    return Decision([bool(a * side < -params.split) for a in along],
                    unsure=True, by_head=by_head, against=against)


def either_side(positions: np.ndarray, bound: np.ndarray) -> np.ndarray:
    """The 95 % ``bound`` (15,) of a body at ``positions`` grown, for each
    left and right joint, to take in its partner on the other side and
    that one's bound: where the views' labels are in doubt, the fused
    left hand may be the right one."""
    reach = np.linalg.norm(positions - turned(positions), axis=1) \
        + turned(bound)
    return np.fmax(bound, reach)


def _hands(views: List[Observation], axis: np.ndarray,
           params: FacingParams) -> List[List[Tuple[float, float]]]:
    """Per view, each hand it sees (confidence ``params.confidence`` or
    more): its confidence and how far (m) it lies along ``axis`` from the
    view's trunk centre."""
    out: List[List[Tuple[float, float]]] = []
    for o in views:
        centre = o.positions[TRUNK].mean(axis=0)
        out.append([(float(o.confidence[j]),
                     float((o.positions[j] - centre) @ axis))
                    for j in HANDS if o.confidence[j] >= params.confidence
                    and np.isfinite(o.positions[j]).all()]
                   if np.isfinite(centre).all() else [])
    return out


def _side(hands: List[List[Tuple[float, float]]],
          params: FacingParams) -> float:
    """1 or -1: the side of the axis the ``hands`` (``_hands``) say is the
    front, where ``params.views`` views or more see one and, weighted by
    confidence, they lie ``params.margin`` or more to that side with none
    as far to the other; 0 where they say nothing."""
    seen = [h for view in hands for h in view]
    if sum(1 for view in hands if view) < params.views:
        return 0.0
    reach = sum(c * a for c, a in seen) / sum(c for c, _ in seen)
    side = float(np.sign(reach))
    if abs(reach) < params.margin or \
            any(a * side <= -params.margin for _, a in seen):
        return 0.0
    return side


def _head_side(views: List[Observation], axis: np.ndarray,
               params: FacingParams, margin: float) -> float:
    """1 or -1: the side of the axis the head leads the trunk's line to
    (from the hips' centre through the neck, extended by the neck-head
    length) by ``margin`` or more, weighted by confidence,
    where ``params.views`` views or more see the head, neck and hips
    (centre joints and the hips' mean: the same whichever arm a view
    calls left); 0 where it does not."""
    leads, weights = [], []
    for o in views:
        if not _sees(o, CENTRE, params):
            continue
        weight = float(min(o.confidence[CENTRE]))
        trunk = o.positions[NECK] - o.positions[HIPS].mean(axis=0)
        head = o.positions[HEAD] - o.positions[NECK]
        length = float(np.linalg.norm(trunk))
        if length < 1e-6:
            continue
        leads.append(float(head @ axis - (trunk @ axis)
                           * np.linalg.norm(head) / length))
        weights.append(weight)
    if len(leads) < params.views:
        return 0.0
    lead = float(np.average(leads, weights=weights))
    return float(np.sign(lead)) if abs(lead) >= margin else 0.0


def _knees_straight(views: List[Observation],
                    params: FacingParams) -> bool:
    """Whether the legs give the trackers no cue to the front: in the
    views that see hips, knees and feet (confidence ``params.confidence``
    or more; ``params.views`` or more), the more bent knee lies under
    ``params.knee_bend`` off its hip-foot line (median over the views)."""
    bends = []
    for o in views:
        legs = [o.positions[leg] for leg in LEGS if _sees(o, leg, params)]
        if len(legs) == 2:
            bends.append(max(_bend(*leg) for leg in legs))
    return len(bends) >= params.views \
        and float(np.median(bends)) < params.knee_bend


def _sees(view: Observation, joints: List[int],
          params: FacingParams) -> bool:
    """Whether ``view`` gives every one of ``joints``, at confidence
    ``params.confidence`` or more."""
    return bool(min(view.confidence[joints]) >= params.confidence
                and np.isfinite(view.positions[joints]).all())


def _bend(hip: np.ndarray, knee: np.ndarray, foot: np.ndarray) -> float:
    """How far (m) the knee lies off the line from the hip to the foot."""
    line = foot - hip
    length = float(np.linalg.norm(line))
    if length < 1e-6:
        return float(np.linalg.norm(knee - hip))
    off = knee - hip
    return float(np.linalg.norm(off - line * (off @ line) / length ** 2))


class HeldFront:
    """One person's front as the hands last decided it, held where they
    say nothing. Hands that say the other side from a held front once
    decide nothing (one instant can be a tracker's slip, which the held
    front would then keep); said again within ``confirm_within`` s, with
    no decision for the held front between, and at more instants within
    it than the hands said the held front, they replace it."""

    def __init__(self, params: FacingParams):
        self.params = params
        self.times: List[float] = []    # the hands' recent decisions
        self.against: List[float] = []  # ... against the held front
        self.confirmed: Optional[float] = None  # when they last confirmed
        self.front: Optional[np.ndarray] = None

    def views_to_turn(self, t: float, views: List[Observation]) -> Decision:
        """views_to_turn at instant ``t``, the front held within ``hold`` s
        of the hands' last confirming it."""
        held = self.front if self.confirmed is not None \
            and t - self.confirmed <= self.params.hold else None
        within = self.params.confirm_within
        self.against = [s for s in self.against if t - s <= within]
        self.times = [s for s in self.times if t - s <= within]
        decision = views_to_turn(
            views, self.params, held,
            len(self.against) + 1 >= self.params.confirm
            and len(self.against) + 1 > len(self.times))
        if decision.against is not None:
            self.against.append(t)
        if decision.front is not None:
            if held is not None and decision.front @ held < 0:
                self.times = self.against       # they confirm it
            self.against = []
            self.times = self.times + [t]       # both pruned above
            self.front = decision.front
            if len(self.times) >= self.params.confirm:
                self.confirmed = t
        return decision

    def turn_with(self, positions: np.ndarray) -> None:
        """The held front turns with the body fused at ``positions``; where
        that body's front points the other way from one instant to the
        next (its labels exchanged, as no one turns about that fast), the
        hands never said it, and their decisions for the front before
        confirm it no more."""
        if self.front is not None:
            now = front(positions)
            if now is not None:
                if now @ self.front < 0:
                    self.times = []
                self.front = now
