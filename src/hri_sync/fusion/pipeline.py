"""The fusion loop: skeletons of several views in, fused people out at
common instants on the global clock, on an injected clock.

``add`` takes each view's skeleton as it arrives (its global capture
stamp, Skeleton-frame joints, confidences and the stamp's 95 %
uncertainty; one stamped over ``max_ahead`` s ahead of the clock, or
``max_age`` s behind it and the newest skeleton of any view, is left out,
and so are joints no sensor measures: NaN, at the sensor's origin or
farther than ``max_depth``);
``poll`` fuses every instant ``k / rate`` that is ready:
every live view has a sample at or after it (so interpolation, not
extrapolation, brings each view there), or the frame a view owes it is
overdue (its first frame at or after the instant, on the view's frame
grid, plus its p99 pipeline latency: a lost frame; the view is then
extrapolated a little or left out). A stalled view, a frozen one (its
skeletons repeat, joint for joint, the one before: no new measurement,
left out) or one with a lost clock is not waited for.
Each view's tracker profile (hri_sync.fusion.profile) dates its skeletons
(stamp minus the tracker's delay; each joint re-dated by the tracker
filter's lag at its speed, hri_sync.fusion.lag) and corrects its joints
first; where a profile says a view errs more on the arms as it sees more
of the body's back, each person is fused twice: once to find where the
body faces, then with each view's arms weighted by its vantage on that
body; where the profile has a learned error model
(hri_sync.fusion.errors), once more with the views' joints weighed
against each other by it, given where they lie on the body fused so
far. Before that, where the views disagree on which way the person
faces, those facing away from where the hands reach are turned
(hri_sync.fusion.facing; views that all agree on a front the head
leads away from are turned to the head where no knee bends; where the
hands do not tell at the instant, or the head leads away from the front
all views agree on, each left and right joint's bound takes in its
partner on the other side); a view
whose tracker took the body's back for its front is turned back, and
one whose tracker exchanged the left and right arms has them put back
(hri_sync.fusion.arms), against the person's body predicted from its
last two fused instants, and each view's joints that body has outside
the view's image are left out (its tracker did not see them); after
the first fusion, so is each view's hand farther from the fused elbow
than an arm reaches (hri_sync.fusion.reach). A view's
skeleton of someone farther than its sensor tracks (``sight.far``) is
taken to err more than its profile says: its sigma grows linearly to
``far_sigma`` times at the sensor's depth range (``sight.range``), and
stays there beyond. Each person's fused joints then
go through a constant-velocity Kalman filter (hri_sync.fusion.smooth)
and, with a profile's posture, each elbow is taken with where the
shoulder and hand put it (hri_sync.fusion.posture); each joint's bound
is the fused one plus the distance the two moved it.

A view is suspect while its residuals blame it (calibration.Residuals), or
while none of its users joins a person other views agree on and one is
near (a pose wrong by more than the association gate). Its skeletons are
then paired with the others' bodies (calibration.PoseFit); a pose that fits
them becomes the view's (``fitted``: its skeletons, those kept included,
are placed by it; refined on the skeletons that follow, paired with the
bodies the other views fuse of the same people, over ``refine_window``
s), and the view stays ``wrong_pose`` (down-weighted, reported) for the
session; when none does, the people it alone gives are
other people (the associator holds them back until then). Two views that
share no person with any view though the people one of them gives stand in
the other's sight are reported ``unmatched`` (sightlines): with no third
view to agree with, which pose is wrong cannot be told.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field, replace
from typing import Callable, Deque, Dict, Hashable, List, Optional, Tuple

import numpy as np

from hri_sync.fusion.align import Sample, Track
from hri_sync.fusion.arms import (ArmParams, arms_to_exchange,
                                  bodies_to_turn, exchanged, turned)
from hri_sync.fusion.associate import Associator, Key, body_distance, views_of
from hri_sync.fusion.calibration import Fit, PoseFit, Residuals
from hri_sync.fusion.errors import inputs
from hri_sync.fusion.facing import (FacingParams, HeldFront, back_views,
                                    either_side)
from hri_sync.fusion.frames import SensorPose
from hri_sync.fusion.fuse import (FuseParams, Fused, Observation, fuse,
                                  own_sigma)
from hri_sync.fusion.lag import FilterLag
from hri_sync.fusion.profile import Profile
from hri_sync.fusion.reach import ReachParams, out_of_reach
from hri_sync.fusion.smooth import SmoothParams, Smoother
from hri_sync.fusion.sightlines import (SightParams, Sightlines, distance,
                                        outside_image)
from hri_sync.fusion.views import NOTED, Deafness, HealthParams, ViewHealth
from hri_sync.wire.vocabulary import NUM_JOINTS


@dataclass
class FusionParams:
    """Everything the fusion is tuned by."""

    rate: float = 30.0                  # Hz, common instants
    max_extrapolation: float = 0.04     # s past a view's newest sample
    max_ahead: float = 0.2              # s a stamp may be ahead of now
    max_age: float = 2.0                # s a stamp may be behind now
    max_depth: float = 10.0             # m, a joint from its sensor
    max_gap: float = 0.25               # s between samples interpolated
    wait_margin: float = 0.005          # s past a view's expected arrival
    suspect_weight: float = 0.1         # a wrong-pose view's weight
    scatter_hold: float = 0.5           # s a joint's bound keeps the
                                        # views' largest scatter
    far_sigma: float = 3.0              # a view's error at its sensor's
                                        # depth range, times its profile's
    skip_after: float = 1.0             # s behind the newest: skip ahead
    fuse: FuseParams = field(default_factory=FuseParams)
    smooth: SmoothParams = field(default_factory=SmoothParams)
    arms: ArmParams = field(default_factory=ArmParams)
    facing: FacingParams = field(default_factory=FacingParams)
    reach: ReachParams = field(default_factory=ReachParams)
    health: HealthParams = field(default_factory=HealthParams)
    gate: float = 0.5                   # m, association (associate.py)
    residual_threshold: float = 0.2     # m, wrong pose (calibration.py)
    refit: float = 0.5                  # s between a suspect view's fits
    refine_window: float = 20.0         # s of pairs a fitted pose is
                                        # refined on
    refine_gain: float = 0.1            # share of the residual a refined
                                        # pose must take off
    sight: SightParams = field(default_factory=SightParams)


@dataclass
class Person:
    """One fused person at an instant."""

    person: int
    body: Fused
    newest: float               # newest capture used (global, s)
    sides_in_doubt: bool = False  # its left and right may be exchanged


@dataclass
class ViewUser:
    """What the fusion keeps of one view's user (a track): its samples
    in world, its tracker filter's lag, and its last skeleton as sent
    (stamp, Skeleton-frame joints: a repeat is told by it)."""

    track: Track
    lag: Optional[FilterLag]
    last: Tuple[float, np.ndarray]


@dataclass
class PersonState:
    """What the fusion keeps of one person between instants: its joints'
    filter, its last two fused instants (t, positions), within
    ``scatter_hold`` the views' scatter of each joint (t, scatter), and
    the front its hands last decided (hri_sync.fusion.facing)."""

    smoother: Smoother
    facing: HeldFront
    past: List[Tuple[float, np.ndarray]] = field(default_factory=list)
    scatter: List[Tuple[float, np.ndarray]] = field(default_factory=list)


@dataclass
class Frame:
    """The fused people at one instant."""

    stamp: float                # the instant (global, s)
    people: List[Person]
    published: float            # clock at output


class Fusion:
    """Views' skeletons to fused people."""

    def __init__(self, poses: Dict[str, SensorPose],
                 params: Optional[FusionParams] = None,
                 clock: Callable[[], float] = lambda: 0.0,
                 profiles: Optional[Dict[str, Profile]] = None) -> None:
        self.params = params or FusionParams()
        self.clock = clock
        self.poses = dict(poses)
        self.profiles = {v: (profiles or {}).get(v) or Profile()
                         for v in poses}
        self.posture = next((p.posture for p in self.profiles.values()
                             if p.posture is not None), None)
        self.health = {v: ViewHealth(self.params.health) for v in poses}
        self.deafness = Deafness(self.params.health.deaf_after)
        self.users: Dict[Key, ViewUser] = {}
        self.persons: Dict[int, PersonState] = {}
        self.associator = Associator(gate=self.params.gate)
        self.residuals = Residuals(threshold=self.params.residual_threshold)
        self.pose_fit = PoseFit(threshold=self.params.residual_threshold)
        self.pose_refine = PoseFit(window=self.params.refine_window,
                                   threshold=self.params.residual_threshold)
        self.fitted: Dict[str, Fit] = {}    # view: (pose, before, after)
        self.tried: Dict[str, float] = {}   # view: when its pose was fitted
        self.sightlines = Sightlines(self.params.sight)
        # Called with each person's views and fused body at every instant
        # (t, person, observations as fused, Fused): a bench's recorder.
        self.inspect: Optional[Callable[[float, int, List[Observation],
                                         Fused], None]] = None
        self.next_k: Optional[int] = None
        # Each fused body's output time less the newest capture it used.
        self.latencies: Deque[float] = deque(maxlen=300)
        # When a skeleton came over max_age after its capture, as late as
        # every view's newest: the fusion (or its host's clock) is behind.
        self.behind: Deque[float] = deque(maxlen=1000)

    def sensor_said(self, view: str, level, message) -> Optional[str]:
        """A view's sensor status (diagnostic level 0-3 and message, as
        its tracker's ``sensor_status``); the reason when it is left out
        (counted)."""
        if view not in self.poses:
            return 'unknown_view'
        if not isinstance(level, int) or not 0 <= level <= 3 \
                or not isinstance(message, str):
            self.health[view].reject('bad_sensor_status')
            return 'bad_sensor_status'
        now = self.clock()
        self.health[view].sensor = (now, message)
        self.deafness.heard(now)
        return None

    def add(self, view: str, user: Hashable, stamp: float,
            positions: np.ndarray, confidence: np.ndarray,
            uncertainty: float) -> Optional[str]:
        """One skeleton as it arrives; the reason when it is left out.
        ``stamp``: global capture time; ``positions``: Skeleton frame;
        ``uncertainty``: inf when the view's clock model is lost."""
        if view not in self.poses:
            return 'unknown_view'
        health, now = self.health[view], self.clock()
        fault = self._stamp_fault(stamp, uncertainty, now)
        if fault is None:
            positions = np.array(positions, float)
            confidence = np.nan_to_num(np.array(confidence, float), nan=0.0)
            if positions.shape != (NUM_JOINTS, 3) \
                    or confidence.shape != (NUM_JOINTS,):
                fault = 'bad_joint_count'
        if fault is not None:
            if fault in NOTED:
                health.note(fault, now)
            health.reject(fault)
            return fault
        faults = self._leave_out_joints(positions, confidence)
        profile, known = self.profiles[view], self.users.get((view, user))
        repeated = known is not None and stamp > known.last[0] \
            and np.isfinite(positions).any() \
            and np.array_equal(positions, known.last[1], equal_nan=True)
        if known is None:
            known = self.users[(view, user)] = ViewUser(
                Track(max_gap=self.params.max_gap), profile.filter_lag(),
                (stamp, positions))
        known.last = (stamp, positions)
        health.arrived(now, stamp, uncertainty,
                       faults + (('repeated',) if repeated else ()))
        if repeated:
            health.reject('repeated_skeleton')
            return 'repeated_skeleton'
        self.deafness.heard(now)
        world = profile.place(positions, self.poses[view], stamp, known.lag)
        if not known.track.add(Sample(
                stamp - profile.delay, world, np.clip(confidence, 0, 1),
                uncertainty + profile.delay_spread, stamp)):
            health.reject('repeated_stamp')
            return 'repeated_stamp'
        return None

    def _leave_out_joints(self, positions: np.ndarray,
                          confidence: np.ndarray) -> Tuple[str, ...]:
        """Make NaN, at confidence 0, the joints no sensor measures (NaN,
        at the sensor's origin, beyond ``max_depth``); which of those
        faults the skeleton has."""
        bad = {
            'nan_joints': ~np.isfinite(positions).all(axis=1),
            'zero_joints': (positions == 0).all(axis=1),
            'far_joints': np.linalg.norm(np.where(np.isfinite(positions),
                                                  positions, 0.0), axis=1)
            > self.params.max_depth}
        missing = np.logical_or.reduce(list(bad.values()))
        confidence[missing] = 0.0
        positions[missing] = np.nan
        return tuple(fault for fault, where in bad.items() if where.any())

    def _stamp_fault(self, stamp: float, uncertainty: float,
                     now: float) -> Optional[str]:
        """Why a skeleton's stamp cannot be fused, or None: not finite
        (``bad_stamp``), over ``max_ahead`` ahead of ``now``
        (``future_stamp``), over ``max_age`` behind it and the newest of
        any view (``stale_stamp``; as new as that, it is this node that
        is behind: counted in ``behind``, fused)."""
        if not math.isfinite(stamp) or math.isnan(uncertainty):
            return 'bad_stamp'
        if stamp > now + self.params.max_ahead:
            return 'future_stamp'
        if stamp < now - self.params.max_age:
            newest = max((h.stamps[-1] for h in self.health.values()
                          if h.stamps), default=-math.inf)
            if stamp < newest - self.params.max_age:
                return 'stale_stamp'
            self.behind.append(now)
        return None

    def _newest(self, view: str) -> float:
        """The newest instant ``view`` shows a body at: its newest capture
        less its tracker's delay."""
        stamps = self.health[view].stamps
        return stamps[-1] - self.profiles[view].delay if stamps \
            else -math.inf

    def _ready(self, t: float, now: float) -> bool:
        """Whether instant ``t`` can be fused now."""
        live = [v for v, h in self.health.items() if h.arrivals
                and not h.stalled(now) and not h.clock_lost()]
        if not live:
            return False
        for v in live:
            if self._newest(v) < t and now < self._due(v, t):
                return False
        return True

    def _due(self, view: str, t: float) -> float:
        """When ``view``'s first sample at or after instant ``t`` should
        have arrived: its first frame captured at or after ``t`` plus the
        tracker's delay, on the frame grid of its newest capture, plus
        its p99 pipeline latency (a frame period later before the grid
        is known)."""
        h = self.health[view]
        period, need = h.period(), t + self.profiles[view].delay
        if period > 0 and h.stamps:
            last = h.stamps[-1]
            capture = last + period * max(1, math.ceil(
                (need - last) / period - 0.1))
        else:
            capture = need + period
        return capture + h.late() + self.params.wait_margin

    def poll(self) -> List[Frame]:
        """Fuse every instant that is ready; the frames in time order."""
        now = self.clock()
        newest = max((self._newest(v) for v in self.health),
                     default=-math.inf)
        if not math.isfinite(newest):
            return []
        rate = self.params.rate
        skip = math.ceil((newest - self.params.skip_after) * rate)
        if self.next_k is None or self.next_k < skip:
            self.next_k = max(skip, math.ceil(min(
                self._newest(v) for v in self.health
                if self.health[v].arrivals) * rate))
        frames = []
        while self._ready(self.next_k / rate, now):
            frames.append(self._fuse_at(self.next_k / rate))
            self.latencies.extend(frames[-1].published - p.newest
                                  for p in frames[-1].people)
            self.next_k += 1
        return frames

    def latency(self) -> float:
        """p95 (s) of the last 300 fused bodies' output time less the
        newest capture each used (NaN before any)."""
        return float(np.percentile(list(self.latencies), 95)) \
            if self.latencies else math.nan

    def _observe(self, t: float) -> Dict[Key, Tuple[Observation, float]]:
        """Each usable track's observation at ``t`` and the capture time
        of its newest sample used."""
        out = {}
        for key, known in list(self.users.items()):
            view = key[0]
            if known.track.newest < t - 2.0:
                del self.users[key]
                continue
            if self.health[view].clock_lost():
                continue
            a = known.track.at(t, self.params.max_extrapolation)
            if a is None or not np.isfinite(a.positions).any():
                continue
            weight = self.params.suspect_weight \
                if self.health[view].wrong_pose else 1.0
            profile = self.profiles[view]
            sigma = profile.sigma * self._range_scale(view, a.positions)
            out[key] = (Observation(view, a.positions, a.confidence,
                                    a.speed, a.uncertainty, weight, sigma,
                                    profile.sigma_common,
                                    profile.confidence_power), a.newest)
        return out

    def _fuse_at(self, t: float) -> Frame:
        """Associate, fuse and check the calibration at instant ``t``."""
        obs = self._observe(t)
        ids = self.associator.assign(
            t, {k: o.positions for k, (o, _) in obs.items()},
            lambda key: self.users[key].track.unbroken_since(
                self.associator.forget_after), self.deafness.within)
        groups: Dict[int, List[Key]] = {}
        for key, pid in ids.items():
            groups.setdefault(pid, []).append(key)
        people, bodies = [], {}
        for pid in sorted(groups):
            views = [obs[k][0] for k in groups[pid]]
            state = self.persons.get(pid) or PersonState(
                Smoother(self.params.smooth), HeldFront(self.params.facing))
            self.persons[pid] = state
            before = self._just_before(state.past, t)
            unsure = self._put_sides_right(t, state.facing, before, views)
            self._leave_out_of_image(before, views)
            state.scatter = [(s, x) for s, x in state.scatter
                             if s >= t - self.params.scatter_hold - 1e-9]
            inflate = np.max([x for _, x in state.scatter], axis=0) \
                if state.scatter else None
            body = fuse(views, self.params.fuse, inflate)
            if len(views) > 1:
                scaled = self._by_vantage(body.positions, views)
                left = self._leave_out_of_reach(body.positions, views)
                if scaled or left:
                    body = fuse(views, self.params.fuse, inflate)
                if self._by_error_model(body.positions, views):
                    body = fuse(views, self.params.fuse, inflate)
            if self.inspect is not None:
                self.inspect(t, pid, views, body)
            state.scatter.append((t, body.scatter))
            state.past = (state.past + [(t, body.positions)])[-2:]
            state.facing.turn_with(body.positions)
            bodies[pid] = body
            self.associator.update(pid, body.positions, t)
            if self.associator.held(pid, t):
                continue
            self.residuals.add(t, {o.view: (o.positions, o.confidence)
                                   for o in views})
            newest = max((obs[k][1] for k in groups[pid]
                          if k[0] in body.views), default=t)
            smoothed = state.smoother.update(t, body.positions, body.sigma)
            if self.posture is not None:
                smoothed = self.posture.place(smoothed, body.sigma)
            moved = np.linalg.norm(smoothed - body.positions, axis=1)
            bound = body.bound + np.nan_to_num(moved)
            if unsure:
                bound = either_side(smoothed, bound)
            people.append(Person(pid, replace(
                body, positions=smoothed, bound=bound), newest, unsure))
        self.sightlines.update(t, {pid: (bodies[pid].positions,
                                         {k[0] for k in keys})
                                   for pid, keys in groups.items()},
                               self.poses)
        for pid in [p for p, state in self.persons.items()
                    if state.past[-1][0] < t - 1.0]:
            del self.persons[pid]
        blamed, _ = self.residuals.wrong()
        self._check_poses(t, obs, ids, bodies, blamed)
        for view, health in self.health.items():
            health.wrong_pose = view in blamed or view in self.fitted
        return Frame(t, people, self.clock())

    def _range_scale(self, view: str, positions: np.ndarray) -> float:
        """How many times its profile's sigma ``view`` errs on the body at
        ``positions`` (world): 1 up to ``sight.far`` from its sensor along
        the floor, then growing linearly to ``far_sigma`` at the sensor's
        depth range (``sight.range``: the body at its edge is cut), and
        ``far_sigma`` beyond; its confidence unchanged. A body beyond
        ``sight.far`` is counted."""
        far, edge = self.params.sight.far, self.params.sight.range
        d = distance(positions, self.poses[view].translation())
        if math.isnan(d) or d <= far:
            return 1.0
        self.health[view].beyond_range += 1
        share = min(1.0, (d - far) / (edge - far)) if edge > far else 1.0
        return 1.0 + (self.params.far_sigma - 1.0) * share

    def _just_before(self, past: List[Tuple[float, np.ndarray]],
                     t: float) -> List[np.ndarray]:
        """The person's fused bodies (``past``, oldest first) at the
        instants running up to ``t`` one step apart: the last two, the
        last alone, or none when the last is not the instant before."""
        step = 1.0 / self.params.rate
        run: List[np.ndarray] = []
        for stamp, body in reversed(past):
            if abs(t - stamp - step) > step / 2:
                break
            run.insert(0, body)
            t = stamp
        return run

    def _put_sides_right(self, t: float, facing: HeldFront,
                         before: List[np.ndarray],
                         views: List[Observation]) -> bool:
        """Where the views disagree on the person's front, turn those
        facing away from the hands, or where they say nothing from the
        side the head leads to, and views that all agree on a front the
        head leads away from, on straight legs, to the head (``facing``,
        hri_sync.fusion.facing);
        then turn back the views whose tracker took the body's back for
        its front, and exchange the arms of those whose tracker exchanged
        them (hri_sync.fusion.arms), against the person's body predicted
        from its last two fused instants (``before``, constant velocity);
        counted per view. Whether the labels are in doubt (the hands did
        not decide the front at this instant where the views disagree, or
        the head leads to the back of views that agree)."""
        decision = facing.views_to_turn(t, views)
        self._swap(views, decision.turn, turned,
                   'turned_to_head' if decision.by_head else 'turned_to_hands')
        if len(before) < 2:
            return decision.unsure
        predicted = 2 * before[1] - before[0]
        steps: Tuple[Tuple[Callable[..., List[bool]],
                           Callable[[np.ndarray], np.ndarray], str], ...] = (
            (bodies_to_turn, turned, 'turned_back'),
            (arms_to_exchange, exchanged, 'arms_exchanged'))
        for decide, swap, counter in steps:
            self._swap(views, decide(views, predicted, self.params.arms,
                                     self.params.fuse), swap, counter)
        return decision.unsure

    def _swap(self, views: List[Observation], which: List[bool],
              swap: Callable[[np.ndarray], np.ndarray], counter: str) -> None:
        """Apply ``swap`` to the positions and confidences of the views
        ``which`` says; counted in each one's health as ``counter``."""
        for o, yes in zip(views, which):
            if yes:
                o.positions = swap(o.positions)
                o.confidence = swap(o.confidence)
                health = self.health[o.view]
                setattr(health, counter, getattr(health, counter) + 1)

    def _leave_out_of_image(self, before: List[np.ndarray],
                            views: List[Observation]) -> None:
        """Leave out (confidence 0) each view's joints that the person's
        body has outside that view's image (sightlines.outside_image):
        what the tracker gives there it did not see (a walker's feet below
        the image of a sensor 2 m away); counted per view. The body is
        predicted from its fused instants just before (``before``:
        constant velocity from two, the last alone from one)."""
        if not before:
            return
        predicted = before[0] if len(before) == 1 \
            else 2 * before[1] - before[0]
        for o in views:
            out = outside_image(self.poses[o.view], predicted,
                                self.params.sight) & (o.confidence > 0)
            if out.any():
                o.confidence = np.where(out, 0.0, o.confidence)
                self.health[o.view].out_of_image += int(out.sum())

    def _leave_out_of_reach(self, positions: np.ndarray,
                            views: List[Observation]) -> bool:
        """Leave out (NaN) each view's hands farther from the elbows of
        the body fused at ``positions`` than an arm reaches
        (hri_sync.fusion.reach); counted per view; whether any was."""
        left = False
        for o, mask in zip(views, out_of_reach(views, positions,
                                               self.params.reach)):
            if mask.any():
                o.positions = np.where(mask[:, None], np.nan, o.positions)
                o.confidence = np.where(mask, 0.0, o.confidence)
                self.health[o.view].out_of_reach += int(mask.sum())
                left = True
        return left

    def _by_vantage(self, positions: np.ndarray,
                    views: List[Observation]) -> bool:
        """Scale each view's sigma by where its sensor stands to the body
        at ``positions`` (its profile's ``vantage``); whether any
        changed."""
        changed = False
        backs = back_views(positions, [self.poses[o.view].translation()
                                       for o in views])
        for o, back in zip(views, backs):
            o.scale = self.profiles[o.view].vantage(back)
            changed |= o.scale is not None
        return changed

    def _by_error_model(self, positions: np.ndarray,
                        views: List[Observation]) -> bool:
        """Weigh the views' joints by their profiles' learned error model
        (hri_sync.fusion.errors) at the body fused at ``positions``: the
        model says how the views' errors on each joint compare, their
        level (over the views that give the joint, geometric mean) stays
        the profiles' (the model, fitted on a dancer, would tighten a
        walker's bounds) and the range's growth (``far_sigma``) stays on
        top; a view farther from the person or nearer than the model knows
        keeps its profile's. Whether any view was weighed by a model."""
        modelled, was, now = [], [], []
        backs = back_views(positions, [self.poses[o.view].translation()
                                       for o in views])
        for o, back in zip(views, backs):
            profile = self.profiles[o.view]
            sensor = self.poses[o.view].translation()
            if profile.errors is None or \
                    not profile.errors.knows(distance(positions, sensor)):
                continue
            base = own_sigma(profile.sigma, o.confidence, o.power,
                             self.params.fuse.min_confidence)
            modelled.append(o)
            was.append(np.ones(NUM_JOINTS) if o.scale is None else o.scale)
            now.append(np.sqrt(profile.errors.predict(inputs(
                o.positions, o.confidence, base * was[-1], positions,
                sensor, back)) / 3.0) / base)
        if not modelled:
            return False
        finite = np.array([np.isfinite(o.positions).all(axis=1)
                           for o in modelled])
        gives = finite & (np.array([o.confidence for o in modelled])
                          >= self.params.fuse.min_confidence)
        gives = np.where(gives.any(axis=0), gives, finite)     # guesses
        level = (np.log(was) - np.log(now)) * gives
        scale = np.array(now) * np.exp(level.sum(axis=0)
                                       / np.maximum(gives.sum(axis=0), 1))
        for o, new, old in zip(modelled, scale, was):
            o.scale = np.where(np.isfinite(new) & (new > 0), new, old)
        return True

    def _check_poses(self, t: float, obs: Dict[Key, Tuple[Observation,
                                                         float]],
                     ids: Dict[Key, int], bodies: Dict[int, Fused],
                     blamed: List[str]) -> None:
        """Pair the suspect views' skeletons with the others' bodies, and
        fit their poses (every ``refit`` s at most)."""
        agreed = {p: v for p, v in views_of(ids).items() if len(v) > 1}
        shared = {v for views in agreed.values() for v in views}
        suspects = set()
        for key, (o, _) in obs.items():
            view, pid = key[0], ids.get(key)
            if view in self.fitted and pid in agreed:
                self.pose_refine.add(
                    t, view, self.poses[view].from_world(o.positions),
                    fuse([p for k, (p, _) in obs.items()
                          if k[0] != view and ids.get(k) == pid],
                         self.params.fuse).positions, o.confidence)
            if view in blamed and pid in agreed:
                target: Optional[np.ndarray] = bodies[pid].positions
            elif view not in shared:
                target = self._nearest(o.positions, view, agreed, bodies)
            else:
                continue
            if target is not None:
                suspects.add(view)
                self.pose_fit.add(t, view, self.poses[view].from_world(
                    o.positions), target, o.confidence)
        for view in sorted(suspects):
            if t - self.tried.get(view, -math.inf) >= self.params.refit:
                self.tried[view] = t
                fit = self.pose_fit.fit(view, self.poses[view])
                if fit is not None and self.pose_fit.good(fit):
                    self._adopt(view, fit)
                elif fit is not None:       # they are other people
                    self.associator.release(view)
        for view in sorted(set(self.fitted) - suspects):
            if t - self.tried.get(view, -math.inf) >= self.params.refit:
                self.tried[view] = t
                self._refine(view)

    def _refine(self, view: str) -> None:
        """Refit a fitted view's pose on its last ``refine_window`` s of
        skeletons and the bodies the other views fused of the same
        people; adopted when it takes ``refine_gain`` of the residual
        off (the first fit, on 3 s, may have had little to go on)."""
        fit = self.pose_refine.fit(view, self.poses[view])
        if fit is not None and \
                fit[2] <= fit[1] * (1 - self.params.refine_gain):
            self._adopt(view, (fit[0], self.fitted[view][1], fit[2]))

    def _nearest(self, positions: np.ndarray, view: str,
                 agreed: Dict[int, set], bodies: Dict[int, Fused]
                 ) -> Optional[np.ndarray]:
        """The body of the nearest person other views agree on, within
        the associator's ``hold_near``, or None."""
        near = [(d, p) for p in agreed if view not in agreed[p]
                for d in [body_distance(positions, bodies[p].positions)]
                if d <= self.associator.hold_near]
        return bodies[min(near)[1]].positions if near else None

    def _adopt(self, view: str, fit: Fit) -> None:
        """``view``'s fitted pose: its skeletons, kept ones too, are
        placed by it from now on."""
        pose, old = fit[0], self.poses[view]
        for (v, _), known in self.users.items():
            for sample in known.track.samples if v == view else ():
                sample.positions = pose.to_world(old.from_world(
                    sample.positions))
        self.poses[view] = pose
        self.fitted[view] = fit
        self.pose_fit.forget(view)

    def faults(self) -> Dict[str, List[Tuple[str, str]]]:
        """Each view's faults now (views.ViewHealth.faults), and
        ``unmatched`` when it and another view share no person though one
        of them gives people in the other's sight (sightlines)."""
        now = self.clock()
        unmatched = self.sightlines.disagreeing()
        out = {}
        for view, health in sorted(self.health.items()):
            out[view] = health.faults(now) + [
                ('unmatched', "shares no person with view %s (nor with "
                 "any view), though the people one of the two gives stand "
                 "in the other's sight (%.2f m apart): a pose is wrong by "
                 "more than the association gate (fusion_refine refits it) "
                 "or a view is blind there" % (other, apart))
                for other, apart in unmatched.get(view, ())]
        return out
