"""Safety stops of the base: zero velocity when the robot can no longer
trust what it is doing.

No ROS and no clock reading of its own: a :class:`Watchdog` is given its
local clock (``clock()``: s, the clock the robot's commands and receipts
are timed by) and the robot's global clock model (``clock_model()``: a
``hri_sync.clock.model.ClockModel``, or None before any), and judges
what ``nodes/turtlebot_gesture`` feeds it.  Before every velocity command
the node calls :meth:`Watchdog.check`; a :class:`Trip` it returns means:
publish zero now and end the motion.  The conditions, each with its
*onset* (the instant from which no moving command may be published):

- ``clock_dead``: the global clock has no model, or its last good sync is
  more than ``clock_max_age`` s old (the time server lost: onset = last
  sync + ``clock_max_age``), or its uncertainty exceeds
  ``max_uncertainty`` (onset: when it grew past it);
- ``odom_stale``: while the robot moves (a non-zero command in the last
  ``odom_max_age`` s), no odometry came for ``odom_max_age`` s (onset =
  the last receipt, or the first moving command, + ``odom_max_age``);
- ``base_lagging``: the base does not follow its command stream (stuck,
  slipping, a smoother or mux in the way, rolling on its own; onset: the
  receipt of the odometry that shows it): an odometry velocity that
  matches none of the commands in force during the ``max_lag`` s before
  its receipt (within ``linear_tolerance`` m/s and ``angular_tolerance``
  rad/s), or an odometry pose whose turn or path since the robot last
  rested differs by more than ``heading_tolerance`` rad or
  ``path_tolerance`` m from every point the commands (integrated) reached
  during those ``max_lag`` s (:class:`Tracking`: the velocity test alone
  passes a stuck base in short moves that start and end at rest);
- ``decision_missing``: no decision for a round whose window ended
  ``decision_timeout`` s ago (global; onset = window end + timeout);
- ``decision_stale``: a decision received after that, or whose own stamp
  is more than ``decision_timeout`` s old: it is refused, no gesture.

The first three are states: while one holds, :meth:`check` keeps
returning it (``Trip.new`` only the first time) and no motion may start;
the decision trips are events, once per round.  Every trip is counted
(``health``).  Thread-safe: the inputs come from ROS callbacks while the
node's runner thread checks.
"""
import math
import threading
from collections import Counter, deque
from dataclasses import dataclass
from typing import NamedTuple

from hri_sync.robot.geometry import wrap_angle
from hri_sync.wire.health import ERROR, OK, WARN, Health
from hri_sync.wire.vocabulary import MAX_UNCERTAINTY

CLOCK_DEAD, ODOM_STALE, BASE_LAGGING = 'clock_dead', 'odom_stale', \
    'base_lagging'
DECISION_MISSING, DECISION_STALE = 'decision_missing', 'decision_stale'
REASONS = (CLOCK_DEAD, ODOM_STALE, BASE_LAGGING, DECISION_MISSING,
           DECISION_STALE)


@dataclass(frozen=True)
class SafetyConfig:
    """The watchdog's thresholds (``turtlebot_gesture``'s ``~safety_*``
    params); a threshold <= 0 turns its check off."""

    clock_max_age: float = 12.0       # s since the last good sync
    max_uncertainty: float = MAX_UNCERTAINTY   # s, the clock's bound
    odom_max_age: float = 0.5         # s without odometry while moving
    max_lag: float = 0.5              # s the base may lag its commands
    linear_tolerance: float = 0.1     # m/s
    angular_tolerance: float = 0.5    # rad/s
    heading_tolerance: float = 0.2    # rad, of the turn since rest
    path_tolerance: float = 0.05      # m, of the path since rest
    decision_timeout: float = 5.0     # s after the window end

    def __post_init__(self):
        for name in ('clock_max_age', 'max_uncertainty', 'odom_max_age',
                     'max_lag', 'linear_tolerance', 'angular_tolerance',
                     'heading_tolerance', 'path_tolerance',
                     'decision_timeout'):
            value = getattr(self, name)
            if not isinstance(value, (int, float)) or math.isnan(value):
                raise ValueError('safety %s=%r is not a number'
                                 % (name, value))


class Trip(NamedTuple):
    """A reason to stop the base: ``onset`` in the local clock for the
    states (global for the decision events), ``detail`` in words."""

    reason: str
    onset: float
    detail: str
    round: int = 0
    new: bool = True


class Tracking:
    """The motion the commands ask for (their integral: path along the
    heading, m, and turn, rad) against the motion the odometry poses show,
    both since the robot last rested (``anchor``: told to stop at least
    ``max_lag`` s before, and still)."""

    def __init__(self):
        self.t = None               # time of the last command
        self.v = self.w = 0.0       # the command in force
        self.path = self.turn = 0.0
        self.history = deque()      # (t, path, turn) at each command
        self.pose = None            # the last odometry (x, y, yaw)
        self.odom = (0.0, 0.0)      # its path and turn, integrated
        self.anchor = None          # (commanded, odometry) at the rest

    def command(self, now, linear, angular, keep):
        """A command at ``now``; history kept ``keep`` s back."""
        if self.t is not None:
            dt = now - self.t
            self.path += self.v * dt
            self.turn += self.w * dt
        self.t, self.v, self.w = now, linear, angular
        self.history.append((now, self.path, self.turn))
        while len(self.history) > 1 and self.history[1][0] <= now - keep:
            self.history.popleft()

    def commanded(self, t):
        """(path, turn) the commands reached at ``t``."""
        if self.t is None:
            return 0.0, 0.0
        if t >= self.t:
            return (self.path + self.v * (t - self.t),
                    self.turn + self.w * (t - self.t))
        for (t0, p0, a0), (t1, p1, a1) in zip(
                reversed(list(self.history)[:-1]), reversed(self.history)):
            if t0 <= t:
                f = (t - t0) / (t1 - t0) if t1 > t0 else 1.0
                return p0 + f * (p1 - p0), a0 + f * (a1 - a0)
        return self.history[0][1:]

    def odometry(self, now, pose, at_rest, keep):
        """An odometry ``pose`` (x, y, yaw) received at ``now``; at rest
        (commanded and measured) it anchors.  Returns the error (path m,
        turn rad) against the commands of the last ``keep`` s, or None
        without an anchor."""
        x, y, yaw = pose
        if self.pose is not None:
            px, py, pyaw = self.pose
            mid = pyaw + wrap_angle(yaw - pyaw) / 2.0
            self.odom = (self.odom[0] + (x - px) * math.cos(mid)
                         + (y - py) * math.sin(mid),
                         self.odom[1] + wrap_angle(yaw - pyaw))
        self.pose = (x, y, yaw)
        if at_rest:
            self.anchor = (self.commanded(now), self.odom)
            return 0.0, 0.0
        if self.anchor is None:
            return None
        (cp, ct), (op, ot) = self.anchor
        times = [now - keep] + [h[0] for h in self.history
                                if h[0] > now - keep] + [now]
        points = [self.commanded(t) for t in times]

        def miss(value, reached):
            lo, hi = min(reached), max(reached)
            return max(lo - value, value - hi, 0.0)
        return (miss(self.odom[0] - op, [p - cp for p, _ in points]),
                miss(self.odom[1] - ot, [a - ct for _, a in points]))


class Watchdog:
    """Judges the base's inputs against a ``SafetyConfig``."""

    def __init__(self, config, clock, clock_model):
        self.config = config
        self.clock = clock
        self.clock_model = clock_model
        self.commands = deque()      # (local time, linear, angular)
        self.moving_since = None     # local time of the first non-zero
        self.resting_since = clock()  # of the first zero (or the start)
        self.last_odom = None        # local receipt time
        self.lagging = None          # Trip of the last lagging odometry
        self.tracking = Tracking()
        self.state = None            # the state Trip in force
        self.windows = {}            # round -> window end (global)
        self.decided = set()
        self.declared_missing = set()
        self.trips = Counter()
        self._lock = threading.RLock()

    # --- inputs ----------------------------------------------------------
    def _on_command(self, linear, angular):
        now = self.clock()
        moving = linear != 0.0 or angular != 0.0
        if moving:
            self.resting_since = None
            if self.moving_since is None:
                self.moving_since = now
        else:
            self.moving_since = None
            if self.resting_since is None:
                self.resting_since = now
        self.commands.append((now, linear, angular))
        self.tracking.command(now, linear, angular,
                              max(self.config.max_lag, 0.0))
        horizon = now - max(self.config.max_lag, 0.0)
        while len(self.commands) > 1 and self.commands[1][0] <= horizon:
            self.commands.popleft()

    def _on_odom(self, linear, angular, pose=None):
        now = self.clock()
        self.last_odom = now
        c = self.config
        if c.max_lag <= 0:
            return
        start = now - c.max_lag
        while len(self.commands) > 1 and self.commands[1][0] <= start:
            self.commands.popleft()
        # The commands in force since ``start``; before the first one the
        # base was told nothing: at rest.
        candidates = list(self.commands)
        if not candidates or candidates[0][0] > start:
            candidates.append((start, 0.0, 0.0))
        why = None
        if self.commands and not any(abs(linear - v) <= c.linear_tolerance
                   and abs(angular - w) <= c.angular_tolerance
                   for _, v, w in candidates):
            why = ('odometry %.2f m/s %.2f rad/s matches no command of the '
                   'last %.2f s' % (linear, angular, c.max_lag))
        if pose is not None:
            # At rest: told to stop max_lag ago (not a move's end at a
            # single zero), and still.
            at_rest = (self.resting_since is not None
                       and now - self.resting_since >= c.max_lag
                       and abs(linear) <= c.linear_tolerance
                       and abs(angular) <= c.angular_tolerance)
            miss = self.tracking.odometry(now, pose, at_rest, c.max_lag)
            if miss is not None and why is None and (
                    miss[0] > c.path_tolerance > 0
                    or miss[1] > c.heading_tolerance > 0):
                why = ('its path and turn since rest are %.3f m and %.1f '
                       'deg off the commands of the last %.2f s'
                       % (miss[0], math.degrees(miss[1]), c.max_lag))
        if why is None:
            self.lagging = None
        elif self.lagging is None:
            self.lagging = Trip(BASE_LAGGING, now, 'the base does not follow '
                                'its commands: ' + why)

    def _expect_decision(self, round_id, window_end):
        self.windows[round_id] = window_end

    def _on_decision(self, round_id, now, stamp=None):
        timeout = self.config.decision_timeout
        end = self.windows.pop(round_id, None)   # judged once
        missed = round_id in self.declared_missing
        self.decided.add(round_id)
        if timeout <= 0 or (end is None and not missed):
            return None
        late = -math.inf if end is None else now - (end + timeout)
        old = None if stamp is None else now - stamp - timeout
        if missed or late > 0 or (old is not None and old > 0):
            why = ('after its round was declared without one' if missed
                   else '%.2f s after its deadline (window end + %.1f s)'
                   % (late, timeout) if late > 0 else
                   'stamped %.2f s ago' % (now - stamp))
            return self._count(Trip(DECISION_STALE, now, 'decision of '
                                    'round %d came %s: refused'
                                    % (round_id, why), round_id))
        return None

    # --- judgement -------------------------------------------------------
    def _check(self, global_now=None):
        now = self.clock()
        trip = self._clock_trip(now) or self._odom_trip(now) or self.lagging
        if trip is not None:
            if self.state is not None and self.state.reason == trip.reason:
                return self.state._replace(new=False)
            self.state = self._count(trip)
            return trip
        self.state = None
        if global_now is None or self.config.decision_timeout <= 0:
            return None
        for round_id, end in sorted(self.windows.items()):
            due = end + self.config.decision_timeout
            if round_id not in self.decided and global_now > due:
                self.declared_missing.add(round_id)
                del self.windows[round_id]
                return self._count(Trip(
                    DECISION_MISSING, due, 'no decision for round %d %.1f s '
                    'after its window ended' % (round_id,
                                                self.config.decision_timeout),
                    round_id))
        return None

    def _clock_trip(self, now):
        c = self.config
        model = self.clock_model()
        if model is None or not model.ready:
            return Trip(CLOCK_DEAD, now, 'the global clock has no model')
        age = now - model.local_ref
        if c.clock_max_age > 0 and age > c.clock_max_age:
            return Trip(CLOCK_DEAD, model.local_ref + c.clock_max_age,
                        'the global clock is dead: no good sync for %.1f s '
                        '(limit %.1f s)' % (age, c.clock_max_age))
        uncertainty = model.uncertainty_at(now)
        if c.max_uncertainty > 0 and uncertainty > c.max_uncertainty:
            growth = getattr(model, 'drift_bound', 0.0)
            onset = (model.local_ref + (c.max_uncertainty - model.uncertainty)
                     / growth if growth > 0 else now)
            return Trip(CLOCK_DEAD, min(onset, now), 'the global clock is '
                        'too uncertain: %.3f ms (limit %.3f ms)'
                        % (uncertainty * 1e3, c.max_uncertainty * 1e3))
        return None

    def _odom_trip(self, now):
        c = self.config
        if c.odom_max_age <= 0 or self.moving_since is None:
            return None
        since = self.moving_since if self.last_odom is None else max(
            self.moving_since, self.last_odom)
        if now - since <= c.odom_max_age:
            return None
        what = ('no odometry since moving' if self.last_odom is None
                or self.last_odom < self.moving_since
                else 'last odometry %.2f s ago' % (now - self.last_odom))
        return Trip(ODOM_STALE, since + c.odom_max_age, 'moving without '
                    'odometry: %s (limit %.2f s)' % (what, c.odom_max_age))

    def on_command(self, linear, angular):
        """A velocity command about to be published (after ``check``)."""
        with self._lock:
            self._on_command(linear, angular)

    def on_odom(self, linear, angular, pose=None):
        """An odometry velocity and ``pose`` (x, y, yaw; None: velocity
        only), received now: is the base following?"""
        with self._lock:
            self._on_odom(linear, angular, pose)

    def expect_decision(self, round_id, window_end):
        """Round ``round_id``'s window ends at global ``window_end``."""
        with self._lock:
            self._expect_decision(round_id, window_end)

    def on_decision(self, round_id, now, stamp=None):
        """A decision received at global ``now`` (its own global
        ``stamp``, None: unknown): None if it may be acted on, else the
        ``decision_stale`` Trip (refuse it)."""
        with self._lock:
            return self._on_decision(round_id, now, stamp)

    def check(self, global_now=None):
        """The Trip in force now, or None: a state (``new`` only the first
        time), else a decision missing (once per round; needs the global
        ``global_now``)."""
        with self._lock:
            return self._check(global_now)

    def health(self):
        """The safety stops for /diagnostics: ERROR while a state trip
        holds, WARN once any stop happened, else OK; counts per reason."""
        with self._lock:
            state, trips = self.state, dict(self.trips)
        if state is not None:
            level, message = ERROR, 'base stopped: %s' % state.detail
        elif trips:
            level, message = WARN, 'safety stops so far: %s' % ', '.join(
                '%s %d' % kv for kv in sorted(trips.items()))
        else:
            level, message = OK, 'no safety stop'
        return Health(level, message, tuple(
            (reason, str(trips.get(reason, 0))) for reason in REASONS))

    def _count(self, trip):
        self.trips[trip.reason] += 1
        return trip
