"""DJ Rob's job scheduler: rounds and decisions become motions on the beat.

No ROS and no clock reading of its own: a :class:`DjRob` is given its
clocks (``clock``: global seconds, the schedule's; ``odom_clock``: any
monotonic seconds, for the odometry's age) and a ``log(level, text)``
callable (level 'info', 'warn' or 'error'); ``nodes/turtlebot_gesture``
feeds it the ROS inputs, runs :meth:`DjRob.take` jobs in a thread and
publishes each :class:`Tick`.

- A capture order (``on_capture``) queues a *dance* from the window start
  to its end; a valid winner decision (``on_decision``) queues a
  *gesture* from the window end (or now, if later).  Jobs run one at a
  time, in start order.
- Preemption: a new round's ``/sync_time`` (``on_sync_time``) cuts a
  running gesture short (it brakes at the limits) and drops queued ones;
  a running gesture also brakes as soon as a dance is queued.
- Late join: a dance whose base is still busy more than one tick after
  its start joins the dance on a later beat of the music, or is skipped
  if that beat is past the window end (both logged as errors).
- Decisions are validated: an unknown round, an unknown outcome, a winner
  out of range or a second decision for a round is logged as an error and
  ignored; a winner decided after the next round started gets no gesture.
- The heading a plan starts from is the odometry's, relative to the first
  odometry pose (:func:`hri_sync.robot.geometry.relative_pose`), or, when
  no fresh odometry came, the dead-reckoned heading of the motions run.
- A gesture's turn is checked on fresh odometry once it is over: a base
  that turned short or past the winner by more than ``HEADING_SLACK`` (a
  starved runner whose commands timed out, a slipping wheel) turns again
  before it approaches, up to ``TURN_RETRIES`` times (logged as warnings).
- A dance's turns are re-aimed on fresh odometry as each begins: a base
  off the dance's heading by more than ``HEADING_SLACK`` (an earlier move
  starved) turns by the error more (within the limits, logged as a
  warning), so a dance still ends facing heading 0.  The last turn's own
  error is left to the next plan, which starts from odometry.
"""
import bisect
import math
import threading
from dataclasses import dataclass, replace
from typing import NamedTuple, Optional, Tuple

from hri_sync.robot import choreography as ch
from hri_sync.robot.geometry import relative_pose, wrap_angle
from hri_sync.robot.kobuki import LED_BLACK, ZERO, Limits, Twist
from hri_sync.wire.vocabulary import Outcome

WINNER, NO_WINNER, TIE, ABORTED = OUTCOMES = Outcome.ALL
DANCE, GESTURE = 'dance', 'gesture'
JOIN_SLACK = 0.05       # s: a dance this close before a beat skips it
# A heading error on odometry that a turn takes up: a gesture's turn turns
# again, a dance's next turn turns by it more.  Under half the 2 degrees
# that robots dancing in unison keep between them at rest.
HEADING_SLACK = math.radians(0.75)
TURN_SETTLE = 0.15      # s after the turn's end that its heading is read
TURN_RETRIES = 2


def float_list(value):
    """A list of finite floats from a YAML list or a comma-separated str."""
    if isinstance(value, str):
        value = [v for v in value.replace('[', '').replace(']', '')
                 .split(',') if v.strip()]
    out = [float(v) for v in value]
    if not out or not all(math.isfinite(v) for v in out):
        raise ValueError('need at least one finite number')
    return out


@dataclass(frozen=True)
class Config:
    """How DJ Rob dances and gestures (``turtlebot_gesture``'s params)."""

    bearings: Tuple[float, ...]     # rad from the start, participant 1 first
    distance: Optional[float] = 1.5  # m from the start; None: bearings only
    limits: Limits = Limits()
    margin: float = 0.9
    beat: float = 0.5               # s, the music's beat period
    first_beat: float = 0.0         # s into the window of the first beat
    step: float = 0.15              # m
    step_beats: int = 2
    approach: float = 0.3           # m
    bobble: float = math.radians(20.0)   # head-bobble amplitude, rad
    period: float = 0.02            # s between commands


class Pose(NamedTuple):
    """Where the robot is relative to its start pose, and by what source."""

    x: float
    y: float
    heading: float
    source: str          # 'odometry' or 'dead reckoning'


class Job:
    """A motion to run from global time ``start`` (a dance of the window
    ``scheduled``..``end``, or the gesture to participant ``winner``)."""

    def __init__(self, kind, round_id, start, end=math.inf, winner=0):
        self.kind = kind
        self.round = round_id
        self.start = start          # global; a late dance moves it (begin)
        self.scheduled = start
        self.end = end              # a dance must be over by then
        self.winner = winner
        self.yield_now = False      # set to brake and end early


class Tick(NamedTuple):
    """What to output at one tick of a running job."""

    now: float           # global time of the tick
    twist: Twist         # the velocity command
    first: bool          # the job's first command
    bobble: Optional[float]   # head angle (rad) during a dance, else None
    events: list         # choreography.Event s due (LEDs, sound)
    next: float          # global time of the next tick


class DjRob:
    """The scheduler's state: rounds, decisions, the job queue, the pose.

    Thread-safe: the inputs come from ROS callbacks while a runner thread
    takes and runs the jobs.
    """

    def __init__(self, config, clock, odom_clock, log, name='dj_rob',
                 odom_max_age=1.0):
        if not config.bearings:
            raise ValueError('need at least one participant bearing')
        config.limits.scaled(config.margin)      # checks the margin
        self.config = config
        self.clock = clock
        self.odom_clock = odom_clock
        self.log = log
        self.name = name
        self.odom_max_age = odom_max_age
        self._lock = threading.Lock()
        self.jobs = []              # sorted by start
        self.running = None
        self.rounds = {}            # round -> window end (global)
        self.decided = set()
        self.sync_round = 0         # the latest round whose sync_time came
        self.odom = None            # (odom_clock receipt, x, y, yaw)
        self.origin = None          # the start pose (x, y, yaw) in odom
        self.dead_heading = 0.0     # commanded heading, without odometry

    def _say(self, level, text, *args):
        self.log(level, ('%s: ' + text) % ((self.name,) + args))

    # --- odometry --------------------------------------------------------
    def on_odom(self, x, y, yaw):
        """An odometry pose (odom frame); the first fixes the start pose.
        Raises ValueError for a non-finite one (ignored)."""
        if not all(map(math.isfinite, (x, y, yaw))):
            raise ValueError('odometry with a non-finite pose')
        with self._lock:
            first = self.origin is None
            if first:
                self.origin = (x, y, yaw)
            self.odom = (self.odom_clock(), x, y, yaw)
        if first:
            self._say('info', 'start pose from /odom: (%.3f, %.3f) m, '
                      '%.1f deg', x, y, math.degrees(yaw))

    @property
    def has_odom(self):
        """True once an odometry pose came."""
        return self.odom is not None

    def odom_pose(self):
        """The pose relative to the start pose from odometry no older than
        ``odom_max_age``, or None."""
        with self._lock:
            odom, origin = self.odom, self.origin
        if odom is None or self.odom_clock() - odom[0] > self.odom_max_age:
            return None
        return Pose(*relative_pose(origin, *odom[1:]), 'odometry')

    def pose(self):
        """The pose relative to the start pose: from odometry no older than
        ``odom_max_age``, else (logged as an error) dead reckoning."""
        pose = self.odom_pose()
        if pose is not None:
            return pose
        with self._lock:
            odom = self.odom
        age = ('never received' if odom is None else 'last %.1f s ago'
               % (self.odom_clock() - odom[0]))
        self._say('error', 'no fresh /odom (%s): turning by dead reckoning '
                  'of the commanded motion', age)
        return Pose(0.0, 0.0, wrap_angle(self.dead_heading),
                    'dead reckoning')

    # --- rounds and decisions -------------------------------------------
    def on_capture(self, round_id, start, end, lead):
        """A capture order for a window ``start``..``end`` (global) that
        came ``lead`` s ahead: queue its dance."""
        with self._lock:
            self.rounds[round_id] = end
        self._say('info', 'round %d: scheduled %.2f s ahead', round_id, lead)
        self._add(Job(DANCE, round_id, start, end))

    def on_late(self, round_id, end, reason):
        """A capture order that came too late to dance: the round is known
        (its decision is valid), with no dance."""
        with self._lock:
            self.rounds[round_id] = end
        self._say('error', 'round %d: no dance (%s)', round_id, reason)

    def on_sync_time(self, round_id):
        """A new round starts: its dance must not wait for a gesture."""
        with self._lock:
            self.sync_round = max(self.sync_round, round_id)
            job = self.running
            if job is not None and job.kind == GESTURE:
                job.yield_now = True
                self._say('warn', 'round %d is starting: the winner gesture '
                          'of round %d is cut short (braking)', round_id,
                          job.round)
            for j in [j for j in self.jobs if j.kind == GESTURE]:
                self.jobs.remove(j)
                self._say('warn', 'round %d is starting: the winner gesture '
                          'of round %d is dropped', round_id, j.round)

    def on_decision(self, round_id, outcome, winner, reason=''):
        """A decision: queue the winner gesture, or say why not.

        Returns what was done: 'gesture', 'no_gesture' (no winner),
        'superseded' (a newer round started), or why it was ignored:
        'unknown_round', 'unknown_outcome', 'winner_out_of_range',
        'duplicate'."""
        n = len(self.config.bearings)
        with self._lock:
            end = self.rounds.get(round_id)
            known = sorted(self.rounds)
        if end is None:
            self._say('error', 'decision for round %d ignored: not a round '
                      'this robot was scheduled in (known: %s)', round_id,
                      known or 'none')
            return 'unknown_round'
        if outcome not in OUTCOMES:
            self._say('error', 'round %d: unknown decision outcome %r '
                      'ignored', round_id, outcome)
            return 'unknown_outcome'
        if outcome == WINNER and not 1 <= winner <= n:
            self._say('error', 'round %d: winner %d out of range 1..%d: '
                      'ignored', round_id, winner, n)
            return 'winner_out_of_range'
        with self._lock:
            duplicate = round_id in self.decided
            self.decided.add(round_id)
            newer = self.sync_round if self.sync_round > round_id else 0
        if duplicate:
            self._say('error', 'second decision for round %d ignored',
                      round_id)
            return 'duplicate'
        if outcome != WINNER:
            self._say('info', 'round %d: %s (%s): no gesture', round_id,
                      outcome, reason)
            return 'no_gesture'
        if newer:
            self._say('warn', 'round %d: participant %d wins, but round %d '
                      'has started: no gesture', round_id, winner, newer)
            return 'superseded'
        self._add(Job(GESTURE, round_id, max(self.clock(), end),
                      winner=winner))
        return 'gesture'

    def _add(self, job):
        with self._lock:
            starts = [j.start for j in self.jobs]
            self.jobs.insert(bisect.bisect_right(starts, job.start), job)

    # --- running jobs ----------------------------------------------------
    def take(self):
        """The next job (now running, however far its start), or None."""
        with self._lock:
            self.running = self.jobs.pop(0) if self.jobs else None
            return self.running

    def done(self):
        """The running job is over."""
        with self._lock:
            self.running = None

    def dance_pending(self):
        """True when a dance is queued: a running gesture must give way."""
        with self._lock:
            return any(j.kind == DANCE for j in self.jobs)

    def begin(self, job):
        """Plan ``job`` from where the base is now: a :class:`Run` whose
        ``start`` the caller waits for, or None (a dance skipped)."""
        c = self.config
        now = self.clock()
        if job.kind == GESTURE:              # any time after the window
            job.start = max(job.start, now + 0.001)
        elif now > job.start + c.period:
            # The base was still busy (braking from a gesture): join the
            # dance on a later beat of the music rather than skip it.
            late = now - job.start
            beats = math.floor((late + JOIN_SLACK) / c.beat) + 1
            job.start = job.scheduled + beats * c.beat
            if job.start >= job.end:
                self._say('error', 'round %d: dance skipped: the base was '
                          'busy until the window end', job.round)
                return None
            self._say('error', 'round %d: the base was busy until %.0f ms '
                      'after the window start: the dance joins %.2f s late, '
                      'on the beat', job.round, late * 1e3,
                      job.start - job.scheduled)
        return Run(self, job, *self._plan(job))

    def gesture(self, heading, goal):
        """The winner gesture from ``heading`` to face ``goal`` (rad)."""
        c = self.config
        return ch.winner_gesture(heading, goal, c.limits, c.approach,
                                 margin=c.margin)

    def _plan(self, job):
        """The job's motion from its start (the base is at rest), the
        heading a gesture turns to (None for a dance) and the heading a
        dance starts from (None for a gesture)."""
        c, t0 = self.config, job.start
        if job.kind == DANCE:
            heading = self.pose().heading
            plan = ch.dance(job.end - t0, c.bearings, c.limits, c.beat,
                            c.step, c.step_beats, c.margin,
                            c.first_beat - (t0 - job.scheduled), heading)
            self._say('info', 'round %d: dancing %d moves from %.3f for '
                      '%.2f s, from heading %.1f deg', job.round,
                      len(plan.moves), t0, job.end - t0,
                      math.degrees(heading))
            return plan, None, heading
        x, y, heading, source = self.pose()
        goal = ch.target_heading(x, y, c.bearings[job.winner - 1], c.distance)
        self._say('info', 'round %d: participant %d wins; turning from %.1f '
                  'to %.1f deg (%s)', job.round, job.winner,
                  math.degrees(heading), math.degrees(goal), source)
        return self.gesture(heading, goal), goal, None


def turn_checked_at(plan):
    """Plan time at which ``plan``'s turn to the winner is checked, or
    None (no turn)."""
    for move in plan.moves:
        if move.name == ch.TURN_TO_WINNER:
            return move.end + TURN_SETTLE
    return None


def turns(plan):
    """The indices of ``plan``'s turning moves, in time order."""
    return [i for i, move in enumerate(plan.moves) if move.angle]


class Run:
    """One job being run: what to command at each tick, on the clock."""

    def __init__(self, rob, job, motion, goal=None, heading=None):
        self.rob = rob
        self.job = job
        self.motion = motion
        self.goal = goal            # a gesture's heading (rad), or None
        self.check_at = None if goal is None else turn_checked_at(motion)
        self.planned = motion       # a dance's plan as made
        self.heading = heading      # where a dance started (rad), or None
        self.turns = [] if heading is None else turns(motion)
        self.retries = 0
        self.start = job.start      # global; plan time 0
        self.t0 = job.start
        self.last = ZERO
        self.t_prev = -math.inf
        self.first = True
        self.braking = False

    def tick(self):
        """The outputs at the clock's now, or None once the motion is over.
        A gesture told to yield, or with a dance queued, brakes instead."""
        rob, job, c = self.rob, self.job, self.rob.config
        now = rob.clock()
        t = now - self.t0
        if t >= self.motion.duration:
            return None
        if not self.braking and (job.yield_now or (
                job.kind == GESTURE and rob.dance_pending())):
            self.motion = ch.Brake(self.last, c.limits)
            self.t0, t, self.braking = now, 0.0, True
        elif self.check_at is not None and t >= self.check_at:
            t = self._check_turn(now, t)
        elif self.turns and t >= self.motion.moves[self.turns[0]].start:
            self._reaim(self.turns.pop(0), t)
        twist = self.motion.twist(t)
        bobble = None
        if job.kind == DANCE:
            bobble = ch.head_bobble(t, self.motion.duration, c.beat, c.bobble)
        events = ([] if self.braking
                  else self.motion.events_between(self.t_prev, t + 1e-9))
        first, self.first = self.first, False
        self.t_prev = t + 1e-9
        self.last = twist
        # The next period boundary; a tick on its target (to rounding:
        # now - t0 may come out a hair short) is not repeated.
        k = math.floor(t / c.period + 1e-6) + 1
        return Tick(now, twist, first, bobble, events, self.t0 + k * c.period)

    def _check_turn(self, now, t):
        """After the turn: on fresh odometry off the goal by more than
        HEADING_SLACK, the gesture again from the heading reached (plan
        time 0 now).  Returns the plan time to run."""
        self.check_at = None
        pose = self.rob.odom_pose()
        if pose is None:
            return t
        error = wrap_angle(self.goal - pose.heading)
        if abs(error) <= HEADING_SLACK or self.retries >= TURN_RETRIES:
            return t
        self.retries += 1
        self.rob._say('warn', 'round %d: the turn to the winner ended at '
                      '%.1f deg, %.1f deg off (odometry): turning again',
                      self.job.round, math.degrees(pose.heading),
                      math.degrees(error))
        self.rob.dead_heading += self.motion.heading(t)
        self.motion = self.rob.gesture(pose.heading, self.goal)
        self.check_at = turn_checked_at(self.motion)
        self.t0, self.t_prev = now, -math.inf
        return 0.0

    def _reaim(self, i, t):
        """As a dance's turn ``i`` begins (plan time ``t``, at most a
        period late): on fresh odometry off the dance's heading by more
        than HEADING_SLACK, the turn takes the error up, as far as the limits
        allow in its time."""
        c, move = self.rob.config, self.motion.moves[i]
        pose = self.rob.odom_pose() if t <= move.start + c.period else None
        if pose is None:
            return
        planned = self.heading + self.planned.heading(move.start)
        error = wrap_angle(planned - pose.heading)
        if abs(error) <= HEADING_SLACK:
            return
        lim = c.limits.scaled(c.margin)
        most = ch.max_move_displacement(move.duration, lim.angular,
                                        lim.angular_accel)
        angle = min(max(self.planned.moves[i].angle + error, -most), most)
        self.rob._say('warn', 'round %d: %.1f deg off the dance\'s heading '
                      '(odometry) as its %s begins: turning %.1f deg, not '
                      '%.1f', self.job.round, math.degrees(error), move.name,
                      math.degrees(angle),
                      math.degrees(self.planned.moves[i].angle))
        moves = list(self.motion.moves)
        moves[i] = replace(move, angle=angle)
        self.motion = replace(self.motion, moves=tuple(moves))

    def finish(self):
        """The events still due after the last tick (LEDs off when braked);
        a completed motion adds its turn to the dead-reckoned heading."""
        if self.braking:
            return [ch.Event(0.0, k, LED_BLACK) for k in ('led1', 'led2')]
        self.rob.dead_heading += self.motion.heading(self.motion.duration)
        return self.motion.events_between(self.t_prev, math.inf)
