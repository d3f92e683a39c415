"""DJ Rob's dance and winner gesture: limits, beats, zeros, headings."""
import math

import pytest

from hri_sync.robot import choreography as ch
from hri_sync.robot.geometry import wrap_angle
from hri_sync.robot.kobuki import (LED_BLACK, LED_GREEN, SOUND_CLEANINGEND,
                                   ZERO, KobukiBase, Limits, Twist)

KOBUKI = Limits()
DEG = math.pi / 180.0


def sample(plan, t_end, dt=0.001, t0=-0.5):
    n = int(round((t_end - t0) / dt))
    return [(t0 + i * dt, plan.twist(t0 + i * dt)) for i in range(n + 1)]


@pytest.mark.parametrize('duration', [0.0, 1.0, 2.5, 5.3, 10.0, 33.3, 60.0])
@pytest.mark.parametrize('beat', [0.4, 0.5, 60.0 / 97, 0.75])
def test_dance_within_limits_and_ends_at_rest(duration, beat):
    plan = ch.dance(duration, beat=beat)
    assert ch.check_limits(sample(plan, duration + 1.0), KOBUKI) == []
    assert all(m.end <= duration + 1e-9 for m in plan.moves)
    assert plan.twist(duration) == ZERO
    assert plan.twist(duration + 0.3) == ZERO
    assert plan.twist(-0.01) == ZERO
    assert plan.heading(duration) == pytest.approx(0.0, abs=1e-9)
    assert plan.distance(duration) == pytest.approx(0.0, abs=1e-9)


def test_dance_under_tighter_limits():
    tight = Limits(linear=0.2, angular=1.0, linear_accel=0.2,
                   angular_accel=1.0)
    plan = ch.dance(30.0, limits=tight)
    assert any(m.angle for m in plan.moves)
    assert ch.check_limits(sample(plan, 31.0), tight) == []
    # ... and the same dance under Kobuki limits would break the tight ones
    assert ch.check_limits(sample(ch.dance(30.0), 31.0), tight) != []


def test_dance_moves_on_the_beat_and_turns_between_participants():
    beat = 0.5
    bearings = (25 * DEG, -40 * DEG)
    plan = ch.dance(60.0, bearings=bearings, beat=beat, first_beat=0.25)
    for m in plan.moves:
        k = (m.start - 0.25) / beat
        assert k == pytest.approx(round(k), abs=1e-9), m
        assert m.duration / beat == pytest.approx(round(m.duration / beat))
    turns = [m for m in plan.moves if m.angle]
    faced = [plan.heading(m.end) for m in turns]
    # participant 1, 2, 1, 2, ... then back to the centre at the end
    assert faced[-1] == pytest.approx(0.0, abs=1e-9)
    for i, h in enumerate(faced[:-1]):
        assert h == pytest.approx(bearings[i % 2], abs=1e-9)
    assert len(faced) > 10
    steps = [m for m in plan.moves if m.distance]
    assert steps and all(abs(m.distance) > 0.05 for m in steps)


@pytest.mark.parametrize('start_deg', [30.0, -30.0, 12.0, 150.0, -179.0])
def test_dance_from_a_turned_start(start_deg):
    """After a winner gesture cut short, the dance still turns to the
    participants' bearings and ends between them."""
    h0 = start_deg * DEG
    plan = ch.dance(20.0, heading=h0)
    assert ch.check_limits(sample(plan, 21.0), KOBUKI) == []
    turns = [m for m in plan.moves if m.angle]
    faced = [wrap_angle(h0 + plan.heading(m.end)) for m in turns]
    expect = [30 * DEG, -30 * DEG] * len(faced)
    if start_deg == 30.0:           # already facing participant 1
        expect = expect[1:]
    assert faced[:-1] == pytest.approx(expect[:len(faced) - 1], abs=1e-9)
    assert len(faced) > 4
    assert faced[-1] == pytest.approx(0.0, abs=1e-9)
    # too short to turn back: it stays put rather than overrun the window
    short = ch.dance(0.7, heading=h0)
    assert all(m.end <= 0.7 for m in short.moves)


def test_short_window_dances_in_place():
    plan = ch.dance(1.5)
    assert plan.moves == ()
    assert plan.twist(0.7) == ZERO


def test_dance_rejects_bad_input():
    for kwargs in ({'duration': float('nan')}, {'duration': -1.0},
                   {'duration': 5.0, 'beat': 0.0}):
        with pytest.raises(ValueError):
            ch.dance(**kwargs)
    with pytest.raises(ValueError):
        Limits(linear=float('nan'))
    with pytest.raises(ValueError):
        ch.winner_gesture(float('nan'), 0.0)


def test_check_limits_catches_violations():
    bad = [(0.0, Twist(0.0, 0.0)), (0.02, Twist(0.1, 0.0))]   # 5 m/s^2
    assert ch.check_limits(bad, KOBUKI)
    assert ch.check_limits([(0.0, Twist(0.0, 4.0))], KOBUKI)
    assert ch.check_limits([(0.0, Twist(0.8, 0.0))], KOBUKI)


@pytest.mark.parametrize('heading_deg', [-170, -60, -30, 0, 12, 30, 95, 180])
@pytest.mark.parametrize('target_deg', [30, -30, 150])
def test_winner_gesture_plan(heading_deg, target_deg):
    plan = ch.winner_gesture(heading_deg * DEG, target_deg * DEG)
    assert ch.check_limits(sample(plan, plan.duration + 1), KOBUKI) == []
    end = heading_deg * DEG + plan.heading(plan.duration)
    assert wrap_angle(end - target_deg * DEG) == pytest.approx(0, abs=1e-9)
    assert plan.distance(plan.duration) == pytest.approx(0.0, abs=1e-9)
    assert plan.twist(plan.duration) == ZERO
    turn = wrap_angle((target_deg - heading_deg) * DEG)
    assert abs(plan.heading(plan.duration)) <= math.pi + 1e-9
    assert plan.heading(plan.duration) == pytest.approx(turn, abs=1e-9)
    kinds = {(e.kind, e.value) for e in plan.events}
    assert ('sound', SOUND_CLEANINGEND) in kinds
    assert ('led1', LED_GREEN) in kinds and ('led1', LED_BLACK) in kinds
    last_led = [e for e in plan.events if e.kind == 'led1'][-1]
    assert last_led.value == LED_BLACK
    assert last_led.time == pytest.approx(plan.duration)


def test_target_heading_from_a_displaced_robot():
    b = 30 * DEG
    assert ch.target_heading(0.0, 0.0, b, 2.0) == pytest.approx(b)
    assert ch.target_heading(0.3, 0.0, b) == pytest.approx(b)
    # moved 1 m forward, the participant 2 m out at 30 deg is now wider
    h = ch.target_heading(1.0, 0.0, b, 2.0)
    assert h == pytest.approx(math.atan2(1.0, math.sqrt(3) - 1.0))


def test_head_bobble():
    values = [ch.head_bobble(i * 0.001, 10.0) for i in range(-100, 10101)]
    assert max(abs(v) for v in values) <= 20 * DEG + 1e-12
    assert max(values) > 19 * DEG
    assert ch.head_bobble(0.0, 10.0) == 0.0
    assert ch.head_bobble(10.0, 10.0) == 0.0
    assert abs(ch.head_bobble(9.999, 10.0)) < 0.01 * DEG * 20
    for a, b in zip(values, values[1:]):           # continuous
        assert abs(a - b) < 0.01


def test_brake_within_limits_to_zero():
    brake = ch.Brake(Twist(0.5, -2.0), KOBUKI)
    samples = [(0.0, Twist(0.5, -2.0))] + [
        (i * 0.001, brake.twist(i * 0.001)) for i in range(1, 2000)]
    assert ch.check_limits(samples, KOBUKI) == []
    assert brake.twist(brake.duration) == Twist(0.0, 0.0)
    assert brake.duration == pytest.approx(1.0)


def drive(base, motion, t_start, t_end, rate=50.0, phase=0.0073,
          jitter=0.004):
    """Feed ``motion.twist`` to ``base`` like the nodes do: a 50 Hz
    commander whose timer wakes late by up to ``jitter``, the base stepped
    to each command's arrival and on its own 50 Hz grid."""
    period = 1.0 / rate
    arrivals = []
    k = 0
    while t_start + phase + k * period < t_end:
        t = t_start + phase + k * period
        arrivals.append(t + jitter * ((k * 7919) % 11) / 10.0)
        k += 1
    ticks = []
    t = base.state.stamp
    while t < t_end:
        t += period
        ticks.append(t)
    events = sorted([(t, 'cmd') for t in arrivals]
                    + [(t, 'tick') for t in ticks])
    states = []
    for t, kind in events:
        if t < base.state.stamp:
            continue
        base.step(t)
        if kind == 'cmd':
            tw = motion.twist(t - t_start)
            base.command(tw.linear, tw.angular, t)
        else:
            states.append(base.state.__dict__.copy())
    return states


@pytest.mark.parametrize('winner,bearing', [(1, 30.0), (2, -30.0)])
def test_round_on_the_simulated_base(winner, bearing):
    """Dance for a window, then the winner gesture computed from the
    base's heading: it ends facing the winner, within limits throughout."""
    base = KobukiBase(start=0.0)
    states = drive(base, ch.dance(20.0), 0.0, 21.0)
    s = base.state
    goal = ch.target_heading(s.x, s.y, bearing * DEG, 2.0)
    gesture = ch.winner_gesture(s.theta, goal)
    states += drive(base, gesture, 21.0, 21.0 + gesture.duration + 1.0)
    assert abs(math.degrees(wrap_angle(base.state.theta - goal))) < 2.0
    assert abs(math.degrees(base.state.theta) - bearing) < 10.0
    assert base.accel_limited == 0 and base.velocity_clamped == 0
    assert base.timeouts == 0
    odom = [(st['stamp'], Twist(st['linear'], st['angular']))
            for st in states]
    assert ch.check_limits(odom, KOBUKI) == []
    assert max(abs(t.angular) for _, t in odom) > 0.5
    assert odom[-1][1] == Twist(0.0, 0.0)
