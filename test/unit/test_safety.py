"""hri_sync.robot.safety: the watchdog that stops the base, on a fake clock."""
import math

import pytest

from hri_sync.robot.safety import (BASE_LAGGING, CLOCK_DEAD,
                                   DECISION_MISSING, DECISION_STALE,
                                   ODOM_STALE, SafetyConfig, Watchdog)
from hri_sync.clock.model import ClockModel


class Clock:
    def __init__(self, t=1000.0):
        self.t = t

    def __call__(self):
        return self.t


def make(**config):
    clock = Clock()
    model = ClockModel(local_ref=clock.t, offset=0.5, uncertainty=1e-4,
                       drift_bound=15e-6)
    box = {'model': model}
    dog = Watchdog(SafetyConfig(**config), clock, lambda: box['model'])
    return dog, clock, box


def drive(dog, clock, seconds, twist=(0.2, 0.5), odom=True, period=0.02):
    """Command ``twist`` for ``seconds``, the base following (``odom``) or
    silent; returns the first trip."""
    for _ in range(int(round(seconds / period))):
        trip = dog.check(clock() + 0.5)
        if trip is not None:
            return trip
        dog.on_command(*twist)
        clock.t += period
        if odom:
            dog.on_odom(*twist)
    return None


def test_a_healthy_robot_never_trips():
    dog, clock, box = make()
    box['model'].local_ref = clock.t
    assert drive(dog, clock, 5.0) is None
    dog.on_command(0.0, 0.0)
    clock.t += 0.02
    dog.on_odom(0.0, 0.0)
    assert dog.check() is None
    assert sum(dog.trips.values()) == 0


def test_odometry_that_stops_coming_trips_after_its_max_age():
    dog, clock, _ = make(odom_max_age=0.5)
    assert drive(dog, clock, 1.0) is None
    last = clock.t                     # the last odometry came now
    trip = drive(dog, clock, 2.0, odom=False)
    assert trip.reason == ODOM_STALE and trip.new
    assert trip.onset == pytest.approx(last + 0.5)
    # caught at the first check past the onset: within one tick
    assert trip.onset <= clock.t < trip.onset + 0.02 + 1e-9
    again = dog.check()
    assert again.reason == ODOM_STALE and not again.new
    assert dog.trips == {ODOM_STALE: 1}


def test_no_odometry_at_rest_is_no_trip_but_moving_without_any_is():
    dog, clock, _ = make(odom_max_age=0.5)
    dog.on_command(0.0, 0.0)
    clock.t += 10.0
    assert dog.check() is None
    start = clock.t
    trip = drive(dog, clock, 1.0, odom=False)
    assert trip.reason == ODOM_STALE
    assert trip.onset == pytest.approx(start + 0.5)
    assert 'no odometry since moving' in trip.detail


def test_a_base_that_does_not_follow_its_commands_trips():
    dog, clock, _ = make(max_lag=0.5)
    assert drive(dog, clock, 1.0) is None
    # the wheels block: odometry says rest while the commands go on
    t0 = clock.t
    trip = None
    while trip is None and clock.t < t0 + 2.0:
        trip = dog.check()
        dog.on_command(0.2, 0.5)
        clock.t += 0.02
        dog.on_odom(0.0, 0.0)
    assert trip.reason == BASE_LAGGING
    # the rest had been commanded 1 s before: the first odometry that
    # matches no command of the last 0.5 s is the onset
    assert trip.onset == pytest.approx(t0 + 0.02)
    assert 'does not follow' in trip.detail


def test_a_base_starting_or_lagging_less_than_max_lag_is_fine():
    dog, clock, _ = make(max_lag=0.5)
    # the base follows 0.3 s late (a slow smoother): within max_lag
    history = []
    for k in range(200):
        assert dog.check() is None
        twist = (0.1 * math.sin(k * 0.05), 0.0)
        dog.on_command(*twist)
        history.append(twist)
        clock.t += 0.02
        dog.on_odom(*history[max(0, len(history) - 15)])


def test_a_base_moving_after_the_commands_stopped_trips():
    dog, clock, _ = make(max_lag=0.5)
    dog.on_command(0.0, 0.0)
    trip = None
    for _ in range(100):
        clock.t += 0.02
        dog.on_odom(0.3, 0.0)        # rolling on its own
        trip = trip or dog.check()
    assert trip.reason == BASE_LAGGING


def test_a_clock_without_a_sync_for_too_long_is_dead():
    dog, clock, box = make(clock_max_age=2.0)
    synced = clock.t
    assert drive(dog, clock, 1.9) is None
    trip = drive(dog, clock, 1.0)
    assert trip.reason == CLOCK_DEAD
    assert trip.onset == pytest.approx(synced + 2.0)
    assert trip.onset <= clock.t < trip.onset + 0.02 + 1e-9
    assert 'no good sync' in trip.detail
    # a good sync again clears it
    box['model'] = ClockModel(local_ref=clock.t, offset=0.5,
                              uncertainty=1e-4, drift_bound=15e-6)
    assert dog.check() is None


def test_a_clock_too_uncertain_or_without_a_model_is_dead():
    dog, clock, box = make(clock_max_age=0.0, max_uncertainty=0.001)
    box['model'].drift_bound = 1e-3     # grows 1 ms/s
    synced = clock.t
    trip = drive(dog, clock, 2.0)
    assert trip.reason == CLOCK_DEAD
    assert trip.onset == pytest.approx(synced + 0.9)
    assert 'too uncertain' in trip.detail
    box['model'] = None                   # still dead: not a new trip
    assert dog.check()[::4] == (CLOCK_DEAD, False)
    dog2, _, box2 = make()
    box2['model'] = None
    assert dog2.check().detail == 'the global clock has no model'
    box2['model'] = ClockModel()           # not ready
    assert dog2.check().reason == CLOCK_DEAD


def test_a_missing_decision_trips_once_and_a_late_one_is_stale():
    dog, clock, _ = make(decision_timeout=3.0)
    dog.expect_decision(1, 2000.0)
    dog.expect_decision(2, 2010.0)
    assert dog.check(2002.9) is None
    assert dog.on_decision(2, 2010.5, stamp=2010.01) is None
    trip = dog.check(2003.01)
    assert (trip.reason, trip.round, trip.onset) == (DECISION_MISSING, 1,
                                                     2003.0)
    assert dog.check(2004.0) is None            # once per round
    late = dog.on_decision(1, 2004.0, stamp=2000.02)
    assert late.reason == DECISION_STALE and late.round == 1
    assert 'declared without one' in late.detail
    dog.expect_decision(3, 2020.0)
    late = dog.on_decision(3, 2023.5)
    assert late.reason == DECISION_STALE and 'after its deadline' in \
        late.detail
    dog.expect_decision(4, 2030.0)
    old = dog.on_decision(4, 2030.5, stamp=2026.0)
    assert old.reason == DECISION_STALE and 'stamped 4.50 s ago' in \
        old.detail
    assert dog.trips == {DECISION_MISSING: 1, DECISION_STALE: 3}
    assert dog.on_decision(99, 5000.0) is None   # not a round of ours


def test_thresholds_of_zero_turn_checks_off_and_nan_is_refused():
    dog, clock, box = make(odom_max_age=0, max_lag=0, clock_max_age=0,
                           max_uncertainty=0, decision_timeout=0)
    dog.expect_decision(1, 0.0)
    assert drive(dog, clock, 30.0, odom=False) is None
    assert dog.check(1e9) is None
    with pytest.raises(ValueError):
        SafetyConfig(odom_max_age=math.nan)


def test_health_counts_the_stops_and_says_when_the_base_is_held():
    dog, clock, _ = make(odom_max_age=0.5)
    assert dog.health().level == 0
    drive(dog, clock, 2.0, odom=False)
    h = dog.health()
    assert h.level == 2 and 'base stopped: moving without odometry' in \
        h.message
    assert h.value(ODOM_STALE) == '1' and h.value(CLOCK_DEAD) == '0'
    dog.on_command(0.0, 0.0)
    assert dog.check() is None
    assert dog.health().level == 1


def test_the_reasons_are_the_safety_stop_message_constants():
    import os
    import re
    from hri_sync.robot.safety import REASONS
    path = os.path.join(os.path.dirname(__file__), '..', '..', 'msg',
                        'SafetyStop.msg')
    with open(path) as f:
        constants = re.findall(r'^string [A-Z_]+=(\w+)', f.read(), re.M)
    assert sorted(constants) == sorted(REASONS)


def dance_on_a_base(delay=0.0, stuck=False, **config):
    """DJ Rob's 8 s dance (turns of 30 deg, steps of 7 cm, moves that
    start and end at rest) commanded at 50 Hz to the base model, which
    gets each command ``delay`` s late (or is ``stuck``); the odometry
    (velocity and pose) comes each tick.  The first trip, or None."""
    from hri_sync.robot import choreography as ch
    from hri_sync.robot.kobuki import KobukiBase, Limits
    dog, clock, box = make(**config)
    plan = ch.dance(8.0, (math.radians(30), math.radians(-30)), Limits(),
                    0.5, 0.15, 2, 0.9, 0.0, 0.0)
    base = KobukiBase(start=clock.t)
    for _ in range(50):                 # at rest for a second
        clock.t += 0.02
        dog.on_odom(0.0, 0.0, (0.0, 0.0, 0.0))
    start, queue = clock.t, []
    for k in range(int(9.0 / 0.02)):
        box['model'].local_ref = clock.t           # a fresh clock
        trip = dog.check()
        if trip is not None:
            return trip
        twist = plan.twist(k * 0.02) if k * 0.02 < plan.duration else (0, 0)
        dog.on_command(*twist)
        queue.append((clock.t + delay, twist))
        clock.t = start + (k + 1) * 0.02
        while queue and queue[0][0] <= clock.t and not stuck:
            t, (v, w) = queue.pop(0)
            base.step(t)
            base.command(v, w, t)
        s = base.step(clock.t)
        dog.on_odom(s.linear, s.angular, (s.x, s.y, s.theta))
    return None


def test_a_base_following_the_dance_never_trips():
    assert dance_on_a_base() is None
    assert dance_on_a_base(delay=0.3) is None    # within max_lag


def test_a_stuck_base_in_the_dance_trips_by_either_test():
    by_velocity = dance_on_a_base(stuck=True, heading_tolerance=0,
                                  path_tolerance=0)
    by_pose = dance_on_a_base(stuck=True, linear_tolerance=1e9,
                              angular_tolerance=1e9)
    both = dance_on_a_base(stuck=True)
    assert {by_velocity.reason, by_pose.reason, both.reason} == \
        {BASE_LAGGING}
    assert 'matches no command' in by_velocity.detail
    assert 'deg off the commands' in by_pose.detail
    # the dance starts at 1001: the pose test sees the first step missed
    # (7 cm, in the first second), the velocity test the first turn
    assert 1001.5 < both.onset == by_pose.onset < 1002.5
    assert 1003.0 < by_velocity.onset < 1004.5
    # a base more than max_lag behind
    assert dance_on_a_base(delay=1.0).reason == BASE_LAGGING


def test_the_pose_test_catches_a_base_that_misses_short_moves():
    """Small moves that start and end at rest, below the velocity
    tolerances: only the turn they add up to shows a stuck base."""
    dog, clock, _ = make(angular_tolerance=0.5, heading_tolerance=0.2)
    dog.on_command(0.0, 0.0)
    clock.t += 0.6
    dog.on_odom(0.0, 0.0, (0.0, 0.0, 0.0))          # anchored at rest
    trip = None
    for k in range(200):                            # 0.4 rad/s, 4 s
        trip = trip or dog.check()
        dog.on_command(0.0, 0.4 * math.sin(math.pi * (k % 50) / 50) ** 2)
        clock.t += 0.02
        dog.on_odom(0.0, 0.0, (0.0, 0.0, 0.0))
    assert trip.reason == BASE_LAGGING and 'deg off' in trip.detail
