"""The Kobuki base model: limits, command timeout, odometry."""
import math

import pytest

from hri_sync.robot.kobuki import KobukiBase, Limits, limits_from_params


def run(base, t_end, dt=0.02):
    t = base.state.stamp
    out = []
    while t < t_end - 1e-9:
        t += dt
        out.append(base.step(t).__dict__.copy())
    return out


def test_accelerates_at_the_limit_then_holds_speed():
    base = KobukiBase(start=0.0)
    for k in range(50):                           # 1 s of 0.3 m/s at 50 Hz
        base.command(0.3, 0.0, k * 0.02)
        base.step(k * 0.02 + 0.02)
    assert base.state.linear == pytest.approx(0.3)
    # 0.6 s ramp at 0.5 m/s^2 covers 0.09 m, then 0.4 s at 0.3 m/s
    assert base.state.x == pytest.approx(0.09 + 0.12, abs=1e-6)
    assert base.state.y == pytest.approx(0.0, abs=1e-12)
    # the 0 -> 0.3 jump: slewed 0.01 m/s a step, flagged while more than
    # two steps behind (0.3 / 0.01 - 2 steps)
    assert base.accel_limited == 28
    assert base.timeouts == 0


def test_a_step_returns_a_snapshot_a_later_step_leaves_alone():
    # kobuki_sim publishes a tick's state outside its lock while a
    # command's step may run: a live state gave a stamp of one instant
    # and a velocity of a later one (an odometry acceleration of 0.76
    # m/s^2, limit 0.5, in a fresh clone's dj_rob_right).
    base = KobukiBase(start=0.0)
    base.command(0.3, 0.0, 0.0)
    tick = base.step(0.02)
    seen = tick.__dict__.copy()
    base.step(0.2)
    assert tick.__dict__ == seen
    assert base.state.stamp == pytest.approx(0.2)
    assert tick.linear == pytest.approx(0.01)


def test_command_timeout_stops_the_base():
    base = KobukiBase(start=0.0)
    base.command(0.2, 0.0, 0.0)
    states = run(base, 2.0)
    at = {round(s['stamp'], 2): s for s in states}
    assert at[0.4]['linear'] == pytest.approx(0.2)
    assert at[0.6]['linear'] == pytest.approx(0.2)
    assert at[0.7]['linear'] < 0.2               # timed out after 0.6 s
    assert at[1.1]['linear'] == pytest.approx(0.0)
    assert base.timeouts == 1
    x_stop = at[1.1]['x']
    assert states[-1]['x'] == pytest.approx(x_stop)


def test_refreshed_command_does_not_time_out_and_zero_stops():
    base = KobukiBase(start=0.0)
    for k in range(100):
        base.command(0.0, 1.0, k * 0.05)          # 20 Hz, inside 0.6 s
        base.step(k * 0.05 + 0.05)
    assert base.state.angular == pytest.approx(1.0)
    assert base.timeouts == 0
    base.command(0.0, 0.0, 5.0)
    run(base, 6.0)
    assert base.state.angular == 0.0
    assert base.timeouts == 0                     # an explicit stop


def test_velocity_clamped_and_counted():
    base = KobukiBase(start=0.0)
    for k in range(200):
        base.command(2.0, -10.0, k * 0.02)
        base.step(k * 0.02 + 0.02)
    assert base.state.linear == pytest.approx(0.7)
    assert base.state.angular == pytest.approx(-math.pi)
    assert base.velocity_clamped == 200


def test_arc_closes_a_circle():
    lim = Limits(linear_accel=100.0, angular_accel=1000.0)
    base = KobukiBase(start=0.0, limits=lim)
    v, w = 0.2, 0.5
    base.state.linear, base.state.angular = v, w
    period = 2 * math.pi / w
    t = 0.0
    while t < period - 1e-9:
        base.command(v, w, t)
        t = min(t + 0.02, period)
        base.step(t)
    assert base.state.x == pytest.approx(0.0, abs=1e-6)
    assert base.state.y == pytest.approx(0.0, abs=1e-6)
    # halfway it was 2 r to the left
    base2 = KobukiBase(start=0.0, limits=lim)
    base2.state.linear, base2.state.angular = v, w
    for k in range(int(round(period / 2 / 0.02))):
        base2.command(v, w, k * 0.02)
        base2.step((k + 1) * 0.02)
    assert base2.state.y == pytest.approx(2 * v / w, abs=1e-2)
    # wheels: the right one travels further on a left turn
    assert base.state.right_wheel > base.state.left_wheel > 0
    assert (base.state.right_wheel - base.state.left_wheel) * 0.035 \
        == pytest.approx(w * period * 0.23, rel=1e-6)


def test_long_gap_integrated_in_substeps():
    base = KobukiBase(start=0.0)
    base.command(0.0, 1.0, 0.0)
    base.step(0.5)                                # one call, 25 sub-steps
    assert base.state.angular == pytest.approx(1.0)
    assert base.state.stamp == pytest.approx(0.5)


def test_bad_command_rejected_and_previous_kept():
    base = KobukiBase(start=0.0)
    base.command(0.1, 0.0, 0.0)
    with pytest.raises(ValueError):
        base.command(float('nan'), 0.0, 0.1)
    with pytest.raises(ValueError):
        base.command(0.0, float('inf'), 0.1)
    assert base.command_value.linear == 0.1
    with pytest.raises(ValueError):
        KobukiBase(start=0.0, wheelbase=0.0)


def test_health_counts_what_the_base_did_with_its_commands():
    base = KobukiBase(start=0.0)
    base.command(0.1, 0.0, 0.0)
    assert base.health() == (True, 'commands within limits', (
        ('commands', 1), ('velocity_clamped', 0), ('accel_limited', 0),
        ('timeouts', 0), ('refused', 0)))
    with pytest.raises(ValueError):
        base.command(float('nan'), 0.0, 0.1)
    health = base.health()
    assert not health.ok
    assert health.message == 'commands beyond the limits or refused'
    assert dict(health.counters)['refused'] == 1
    assert dict(health.counters)['commands'] == 1
    clamped = KobukiBase(start=0.0)
    clamped.command(0.0, 4.0, 0.0)
    assert not clamped.health().ok


def test_limits_from_params_defaults_are_the_kobukis():
    asked = []

    def default(name, value):
        asked.append(name)
        return value
    assert limits_from_params(default) == Limits()
    assert asked == ['max_linear', 'max_angular_deg', 'max_linear_accel',
                     'max_angular_accel']
    given = {'max_linear': 0.5, 'max_angular_deg': 90.0,
             'max_linear_accel': 0.4, 'max_angular_accel': 2.0}
    assert limits_from_params(lambda n, d: given[n]) == Limits(
        0.5, math.pi / 2, 0.4, 2.0)
    given['max_angular_deg'] = -1.0
    with pytest.raises(ValueError, match='angular'):
        limits_from_params(lambda n, d: given[n])
