"""DJ Rob's dance and winner gesture as pure functions of time.

A :class:`Plan` is a list of :class:`Move` s on a time line starting at 0.
Each move displaces the robot by a distance (forward, m) and/or an angle
(counter-clockwise, rad) along a raised-cosine velocity profile

    v(t) = D / T * (1 - cos(2 pi t / T)),   0 <= t <= T,

which starts and ends at zero velocity AND zero acceleration, so moves can
follow each other back to back.  Its peak velocity is 2 |D| / T and its
peak acceleration 2 pi |D| / T^2; every move is sized so both stay under
the :class:`Limits` times a safety margin.  Outside its moves a plan
commands exactly zero.

No ROS here: the scheduler (``hri_sync.robot.dj_rob``) evaluates
``plan.twist(t)`` at 50 Hz and ``nodes/turtlebot_gesture`` publishes it as
``geometry_msgs/Twist``.  The base's limits and velocity command
(:class:`Limits`, :class:`Twist`) come from ``hri_sync.robot.kobuki``.
"""
import bisect
import math
from dataclasses import dataclass
from typing import Sequence, Tuple

from hri_sync.robot.geometry import TWO_PI, wrap_angle
from hri_sync.robot.kobuki import (LED_BLACK, LED_GREEN, SOUND_CLEANINGEND,
                                   ZERO, Limits, Twist)

TURN_TO_WINNER = 'turn to winner'   # the winner gesture's turn (a Move name)


def min_move_duration(displacement, max_velocity, max_accel):
    """Shortest raised-cosine move of ``displacement`` within the limits."""
    d = abs(displacement)
    return max(2.0 * d / max_velocity, math.sqrt(TWO_PI * d / max_accel))


def max_move_displacement(duration, max_velocity, max_accel):
    """Largest displacement a raised-cosine move of ``duration`` allows."""
    return min(max_velocity * duration / 2.0,
               max_accel * duration * duration / TWO_PI)


@dataclass(frozen=True)
class Move:
    """One raised-cosine move from ``start`` lasting ``duration`` s."""

    start: float
    duration: float
    distance: float = 0.0
    angle: float = 0.0
    name: str = ''

    @property
    def end(self):
        return self.start + self.duration

    def twist(self, t):
        """The commanded velocity at plan time ``t``."""
        u = (t - self.start) / self.duration
        if not 0.0 < u < 1.0:
            return ZERO
        k = (1.0 - math.cos(TWO_PI * u)) / self.duration
        return Twist(self.distance * k, self.angle * k)

    def progress(self, t):
        """Share of the displacement done at plan time ``t``, 0..1."""
        u = min(max((t - self.start) / self.duration, 0.0), 1.0)
        return u - math.sin(TWO_PI * u) / TWO_PI


@dataclass(frozen=True)
class Event:
    """A discrete output at plan time ``time``: 'led1', 'led2' or 'sound'."""

    time: float
    kind: str
    value: int


@dataclass(frozen=True)
class Plan:
    """Non-overlapping moves and events; zero velocity from ``duration`` on."""

    moves: Tuple[Move, ...] = ()
    events: Tuple[Event, ...] = ()
    duration: float = 0.0

    def __post_init__(self):
        for a, b in zip(self.moves, self.moves[1:]):
            if b.start < a.end - 1e-9:
                raise ValueError('moves %r and %r overlap' % (a.name, b.name))
        if self.moves and self.moves[-1].end > self.duration + 1e-9:
            raise ValueError('plan duration ends before its last move')

    def twist(self, t):
        """The commanded velocity at plan time ``t`` (ZERO outside moves)."""
        i = bisect.bisect_right([m.start for m in self.moves], t) - 1
        if i < 0:
            return ZERO
        return self.moves[i].twist(t)

    def heading(self, t):
        """Heading change (rad) commanded from time 0 to ``t``."""
        return sum(m.angle * m.progress(t) for m in self.moves)

    def distance(self, t):
        """Signed forward travel (m) commanded from time 0 to ``t``."""
        return sum(m.distance * m.progress(t) for m in self.moves)

    def events_between(self, t0, t1):
        """Events with ``t0 <= time < t1``, in time order."""
        return [e for e in self.events if t0 <= e.time < t1]


def _move(start, displacement, limits, linear, beat=None, name=''):
    """A move of ``displacement`` from ``start``, as short as the limits
    allow, rounded up to whole beats when ``beat`` is given."""
    if linear:
        duration = min_move_duration(displacement, limits.linear,
                                     limits.linear_accel)
    else:
        duration = min_move_duration(displacement, limits.angular,
                                     limits.angular_accel)
    if beat:
        duration = beat * max(1, math.ceil(duration / beat - 1e-9))
    if linear:
        return Move(start, duration, distance=displacement, name=name)
    return Move(start, duration, angle=displacement, name=name)


def dance(duration, bearings=(math.radians(30.0), math.radians(-30.0)),
          limits=Limits(), beat=0.5, step=0.15, step_beats=2, margin=0.9,
          first_beat=0.0, heading=0.0):
    """The dance over a capture window of ``duration`` s.

    Phrases of forward-and-back (``step`` m each way, ``step_beats`` beats
    each, shortened if the limits require) and a turn to face the next
    participant (participant 1 first; ``bearings`` in rad from the start
    pose), all on the beat grid ``first_beat + k * beat``.  ``heading`` is
    where the robot faces when the dance starts (rad, the bearings' frame;
    after a winner gesture cut short it is not 0).  The dance ends facing
    heading 0 (between the participants), at rest, by ``duration``; a
    window too short for a move is danced standing still (head only).
    """
    # Over 80 lines: the choreography's steps in the order they are danced.
    if not math.isfinite(heading):
        raise ValueError('dance: start heading is not finite')
    if not (math.isfinite(duration) and duration >= 0.0):
        raise ValueError('dance duration must be >= 0, got %r' % duration)
    if not (math.isfinite(beat) and beat > 0.0):
        raise ValueError('beat period must be > 0, got %r' % beat)
    if len(bearings) < 1:
        raise ValueError('need at least one participant bearing')
    if step_beats < 1:
        raise ValueError('step_beats must be >= 1')
    lim = limits.scaled(margin)
    first_beat = first_beat % beat
    step_time = step_beats * beat
    step = min(step, max_move_displacement(step_time, lim.linear,
                                           lim.linear_accel))
    moves = []
    heading = wrap_angle(heading)
    next_participant = 0
    beat_index = 0            # moves start at first_beat + beat_index * beat
    want_turn = False         # phrase order: step pair, then turn

    def at(index):
        return first_beat + index * beat

    def home_time(h):
        if abs(h) < 1e-9:
            return 0.0
        return _move(0.0, -h, lim, False, beat).duration

    while True:
        placed = False
        options = ('turn', 'pair') if want_turn else ('pair',)
        for kind in options:
            start = at(beat_index)
            if kind == 'pair':
                if step <= 0.0:
                    continue
                fwd = Move(start, step_time, distance=step, name='forward')
                back = Move(fwd.end, step_time, distance=-step, name='back')
                candidate, new_heading = [fwd, back], heading
            else:
                target = bearings[next_participant % len(bearings)]
                delta = wrap_angle(target - heading)
                candidate, new_heading = [], target     # already facing
                if abs(delta) > 1e-6:
                    candidate = [_move(start, delta, lim, False, beat,
                                       'turn to participant %d' % (
                                           next_participant % len(bearings)
                                           + 1))]
            end = candidate[-1].end if candidate else start
            if end + home_time(new_heading) <= duration + 1e-9:
                moves.extend(candidate)
                beat_index = int(round((end - first_beat) / beat))
                heading = new_heading
                if kind == 'turn':
                    next_participant += 1
                want_turn = kind == 'pair'
                placed = True
                break
        if not placed:
            break
    if abs(heading) > 1e-9:
        home = _move(at(beat_index), -heading, lim, False, beat,
                     'turn to centre')
        if home.end <= duration + 1e-9:     # else the window is too short
            moves.append(home)
    return Plan(tuple(moves), (), duration)


def head_bobble(t, duration, beat=0.5, amplitude=math.radians(20.0)):
    """Head-bobble angle (rad) at window time ``t``: one side per beat,
    faded in and out over one beat, zero outside ``[0, duration]``."""
    if not 0.0 < t < duration:
        return 0.0
    envelope = min(1.0, t / beat, (duration - t) / beat)
    return amplitude * envelope * math.sin(math.pi * t / beat)


def target_heading(x, y, bearing, distance=None):
    """Heading (rad) from the robot at (x, y) to a participant placed at
    ``bearing`` (rad) and ``distance`` (m) from the start pose (origin,
    facing +x); ``distance`` None: the bearing itself."""
    if distance is None or not math.isfinite(distance):
        return wrap_angle(bearing)
    px, py = distance * math.cos(bearing), distance * math.sin(bearing)
    if math.hypot(px - x, py - y) < 1e-6:
        return wrap_angle(bearing)
    return math.atan2(py - y, px - x)


def winner_gesture(heading, target, limits=Limits(), approach=0.3,
                   pause=0.3, margin=0.9):
    """Turn from ``heading`` to face ``target`` (rad, the same frame),
    then approach ``approach`` m and back, LEDs green and a sound during
    the approach, LEDs off at the end."""
    for name, value in (('heading', heading), ('target', target),
                        ('approach', approach), ('pause', pause)):
        if not math.isfinite(value):
            raise ValueError('winner gesture: %s is not finite' % name)
    lim = limits.scaled(margin)
    moves = []
    t = 0.0
    turn = wrap_angle(target - heading)
    if abs(turn) > 1e-4:
        moves.append(_move(t, turn, lim, False, name=TURN_TO_WINNER))
        t = moves[-1].end + pause
    events = []
    if approach > 0.0:
        events += [Event(t, 'led1', LED_GREEN), Event(t, 'led2', LED_GREEN),
                   Event(t, 'sound', SOUND_CLEANINGEND)]
        fwd = _move(t, approach, lim, True, name='approach')
        back = _move(fwd.end + pause, -approach, lim, True, name='back')
        moves += [fwd, back]
        t = back.end
    events += [Event(t, 'led1', LED_BLACK), Event(t, 'led2', LED_BLACK)]
    return Plan(tuple(moves), tuple(events), t)


@dataclass(frozen=True)
class Brake:
    """Braking from ``initial`` to rest at the limits' decelerations."""

    initial: Twist
    limits: Limits = Limits()

    @property
    def duration(self):
        return max(abs(self.initial.linear) / self.limits.linear_accel,
                   abs(self.initial.angular) / self.limits.angular_accel)

    def twist(self, t):
        t = max(t, 0.0)

        def ramp(v0, a):
            return math.copysign(max(abs(v0) - a * t, 0.0), v0)
        return Twist(ramp(self.initial.linear, self.limits.linear_accel),
                     ramp(self.initial.angular, self.limits.angular_accel))


def check_limits(samples: Sequence[Tuple[float, Twist]], limits,
                 tolerance=1e-6):
    """Violations in a time series of (t, Twist): a list of strings, empty
    when every velocity and every step's acceleration is within limits."""
    problems = []
    for t, tw in samples:
        if abs(tw.linear) > limits.linear + tolerance:
            problems.append('t=%.3f linear %.4f m/s' % (t, tw.linear))
        if abs(tw.angular) > limits.angular + tolerance:
            problems.append('t=%.3f angular %.4f rad/s' % (t, tw.angular))
    for (t0, a), (t1, b) in zip(samples, samples[1:]):
        dt = t1 - t0
        if dt <= 0.0:
            continue
        acc_l = abs(b.linear - a.linear) / dt
        acc_a = abs(b.angular - a.angular) / dt
        if acc_l > limits.linear_accel + tolerance:
            problems.append('t=%.3f linear accel %.3f m/s^2' % (t1, acc_l))
        if acc_a > limits.angular_accel + tolerance:
            problems.append('t=%.3f angular accel %.3f rad/s^2' % (t1, acc_a))
    return problems
