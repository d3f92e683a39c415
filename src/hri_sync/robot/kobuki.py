"""A Kobuki (Turtlebot 2) base model: differential drive, pure Python.

The lowest layer of the robot above ``geometry``: the base's velocity
command (:class:`Twist`), its limits (:class:`Limits`, the Kobuki's by
default, and the nodes' params for them), its LED and sound values, and
:class:`KobukiBase`, which does what the base does with
``/mobile_base/commands/velocity``: it keeps the last command for
``timeout`` s (0.6 s on the Kobuki) then stops, clamps the command to the
velocity limits, reaches it no faster than the acceleration limits allow,
and integrates the wheels' motion into a pose.  ``nodes/kobuki_sim``
steps it at 50 Hz and publishes the odometry.

It also counts how often a command was NOT followed (clamped to a
velocity limit, or more than two nominal steps' worth of acceleration
away from the current velocity: a commander within the limits that
publishes at the same rate with some jitter may land two of its steps in
one of ours, but never more), so a test can tell a compliant commander
from a base that merely hides a bad one.
"""
import math
from dataclasses import dataclass, replace
from typing import NamedTuple

from hri_sync.robot.geometry import wrap_angle

WHEELBASE = 0.23        # m, Kobuki wheel separation
WHEEL_RADIUS = 0.035    # m
RATE = 50.0             # Hz, the simulator's update rate
TIMEOUT = 0.6           # s, the Kobuki keeps the last command this long

# kobuki_msgs/Led values and kobuki_msgs/Sound values (same numbers as
# hri_sync/Led and hri_sync/Sound).
LED_BLACK, LED_GREEN, LED_ORANGE, LED_RED = 0, 1, 2, 3
SOUND_ON, SOUND_OFF, SOUND_RECHARGE, SOUND_BUTTON = 0, 1, 2, 3
SOUND_ERROR, SOUND_CLEANINGSTART, SOUND_CLEANINGEND = 4, 5, 6
LED_NAMES = {LED_BLACK: 'black', LED_GREEN: 'green', LED_ORANGE: 'orange',
             LED_RED: 'red'}
SOUND_NAMES = {SOUND_ON: 'on', SOUND_OFF: 'off', SOUND_RECHARGE: 'recharge',
               SOUND_BUTTON: 'button', SOUND_ERROR: 'error',
               SOUND_CLEANINGSTART: 'cleaning start',
               SOUND_CLEANINGEND: 'cleaning end'}

# Pose and twist covariances of the simulated wheel odometry (row-major
# 6x6: small for x, y and yaw, huge for the unobserved z, roll, pitch).
ODOM_COVARIANCE = tuple(1e-4 if i in (0, 7, 35) else
                        (1e6 if i in (14, 21, 28) else 0.0)
                        for i in range(36))


class Twist(NamedTuple):
    """A planar velocity command: forward m/s, counter-clockwise rad/s."""

    linear: float = 0.0
    angular: float = 0.0


ZERO = Twist(0.0, 0.0)


@dataclass(frozen=True)
class Limits:
    """Velocity and acceleration limits of the base.

    Defaults are the Kobuki's: 0.7 m/s and 180 deg/s; the accelerations
    are those of the Kobuki driver's acceleration limiter (0.5 m/s^2,
    3.5 rad/s^2).
    """

    linear: float = 0.7
    angular: float = math.pi
    linear_accel: float = 0.5
    angular_accel: float = 3.5

    def __post_init__(self):
        for name in ('linear', 'angular', 'linear_accel', 'angular_accel'):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise ValueError('limit %s must be a positive number, got %r'
                                 % (name, value))

    def scaled(self, factor):
        """These limits times ``factor`` (a safety margin in (0, 1])."""
        if not 0.0 < factor <= 1.0:
            raise ValueError('margin must be in (0, 1], got %r' % factor)
        return Limits(self.linear * factor, self.angular * factor,
                      self.linear_accel * factor, self.angular_accel * factor)


def limits_from_params(get):
    """Limits from the nodes' params, read by ``get(name, default)``:
    ``max_linear`` (m/s), ``max_angular_deg`` (deg/s), ``max_linear_accel``
    (m/s^2) and ``max_angular_accel`` (rad/s^2), defaults the Kobuki's.
    Raises ValueError for a limit that is not a positive number."""
    kobuki = Limits()
    return Limits(
        get('max_linear', kobuki.linear),
        math.radians(get('max_angular_deg', math.degrees(kobuki.angular))),
        get('max_linear_accel', kobuki.linear_accel),
        get('max_angular_accel', kobuki.angular_accel))


class Health(NamedTuple):
    """What the base did with its commands (kobuki_sim's diagnostics)."""

    ok: bool
    message: str
    counters: tuple     # (name, count) pairs


@dataclass
class BaseState:
    """Pose in the odom frame, body velocity, wheel angles, at ``stamp``."""

    stamp: float
    x: float = 0.0
    y: float = 0.0
    theta: float = 0.0
    linear: float = 0.0
    angular: float = 0.0
    left_wheel: float = 0.0      # rad
    right_wheel: float = 0.0     # rad


class KobukiBase:
    """Differential-drive base with velocity/acceleration limits and the
    command timeout.  Times are seconds on any one monotonic clock."""

    def __init__(self, start, limits=Limits(), wheelbase=WHEELBASE,
                 wheel_radius=WHEEL_RADIUS, timeout=TIMEOUT, rate=RATE,
                 accel_tolerance=0.05):
        if not (wheelbase > 0 and wheel_radius > 0 and timeout > 0
                and rate > 0):
            raise ValueError('wheelbase, wheel radius, timeout and rate '
                             'must be positive')
        self.limits = limits
        self.wheelbase = wheelbase
        self.wheel_radius = wheel_radius
        self.timeout = timeout
        self.max_step = 1.0 / rate
        self.slack = 2.0 * (1.0 + accel_tolerance) / rate   # s of accel
        self.state = BaseState(stamp=start)
        self.command_value = Twist()
        self.command_stamp = None
        self.timed_out = True        # no command yet: standing still
        self.velocity_clamped = 0    # commands beyond the velocity limits
        self.accel_limited = 0       # steps the acceleration limit slewed
        self.timeouts = 0            # nonzero commands the timeout ended
        self.commands = 0            # commands taken
        self.refused = 0             # non-finite commands refused

    def command(self, linear, angular, stamp):
        """Take a velocity command received at ``stamp``.

        Raises ValueError for a non-finite value (the command is ignored
        and the previous one keeps ageing toward the timeout)."""
        if not (math.isfinite(linear) and math.isfinite(angular)):
            self.refused += 1
            raise ValueError('non-finite velocity command (%r, %r)'
                             % (linear, angular))
        if (abs(linear) > self.limits.linear + 1e-9
                or abs(angular) > self.limits.angular + 1e-9):
            self.velocity_clamped += 1
        self.command_value = Twist(
            max(-self.limits.linear, min(self.limits.linear, linear)),
            max(-self.limits.angular, min(self.limits.angular, angular)))
        self.command_stamp = stamp
        self.timed_out = False
        self.commands += 1

    def health(self):
        """Counters of commands taken, clamped, slewed, timed out and
        refused; not ok once any was clamped, slewed or refused."""
        bad = self.velocity_clamped or self.accel_limited or self.refused
        return Health(
            not bad,
            ('commands beyond the limits or refused' if bad
             else 'commands within limits'),
            (('commands', self.commands),
             ('velocity_clamped', self.velocity_clamped),
             ('accel_limited', self.accel_limited),
             ('timeouts', self.timeouts),
             ('refused', self.refused)))

    def target(self, now):
        """The velocity the base heads for at ``now`` (zero after timeout)."""
        if self.command_stamp is None:
            return Twist()
        if now - self.command_stamp > self.timeout + 1e-9:
            if not self.timed_out and self.command_value != Twist():
                self.timeouts += 1       # it stopped a moving base
            self.timed_out = True
            return Twist()
        return self.command_value

    def step(self, now):
        """Advance the model to ``now`` (in sub-steps of at most 1/rate);
        returns a copy of the state, which a later step (a command's, in
        another thread) cannot change while the caller reads it."""
        while self.state.stamp < now - 1e-12:
            dt = min(self.max_step, now - self.state.stamp)
            self._substep(dt)
        return replace(self.state)

    def _substep(self, dt):
        s = self.state
        goal = self.target(s.stamp + dt)
        lin = self._slew(s.linear, goal.linear, self.limits.linear_accel,
                         dt)
        ang = self._slew(s.angular, goal.angular,
                         self.limits.angular_accel, dt)
        # Wheel surface speeds, averaged over the step (trapezoid).
        half = self.wheelbase / 2.0
        v = (s.linear + lin) / 2.0
        w = (s.angular + ang) / 2.0
        left, right = v - w * half, v + w * half
        ds = (left + right) / 2.0 * dt
        dth = (right - left) / self.wheelbase * dt
        if abs(dth) < 1e-9:
            dx = ds * math.cos(s.theta + dth / 2.0)
            dy = ds * math.sin(s.theta + dth / 2.0)
        else:
            r = ds / dth
            dx = r * (math.sin(s.theta + dth) - math.sin(s.theta))
            dy = -r * (math.cos(s.theta + dth) - math.cos(s.theta))
        s.x += dx
        s.y += dy
        s.theta = wrap_angle(s.theta + dth)
        s.left_wheel += left * dt / self.wheel_radius
        s.right_wheel += right * dt / self.wheel_radius
        s.linear, s.angular = lin, ang
        s.stamp += dt

    def _slew(self, current, goal, max_accel, dt):
        change = goal - current
        if abs(change) > max_accel * self.slack:
            self.accel_limited += 1
        return current + max(-max_accel * dt, min(max_accel * dt, change))
