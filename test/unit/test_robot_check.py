"""hri_sync.tools.robot_check: DJ Rob's behaviour after a decision."""
import math
from types import SimpleNamespace as NS

import pytest

from hri_sync.tools.robot_check import check_robot, poses
from hri_sync.tools.session import BagClock


def odom(t, x, y, yaw_deg):
    h = math.radians(yaw_deg) / 2
    q = NS(x=0.0, y=0.0, z=math.sin(h), w=math.cos(h))
    pose = NS(position=NS(x=x, y=y), orientation=q)
    return NS(t=t, msg=NS(pose=NS(pose=pose)))


def cmd(t, v, w):
    return NS(t=t, msg=NS(linear=NS(x=v), angular=NS(z=w)))


def turn(to_deg, t0=10.0, t1=12.0, start=0.0):
    """Odometry at 50 Hz turning from ``start`` to ``to_deg`` deg over
    [t0, t1], at rest before and after, until t = 20 s."""
    out = []
    for k in range(1001):
        t = k * 0.02
        a = min(1.0, max(0.0, (t - t0) / (t1 - t0)))
        out.append(odom(t, 0.0, 0.0, start + a * (to_deg - start)))
    return poses(out)


def commands(t0=10.0, t1=12.0):
    return [cmd(t0 - 0.02, 0.0, 0.0)] + \
        [cmd(t0 + k * 0.02, 0.0, 0.5) for k in range(int((t1 - t0) / 0.02))] \
        + [cmd(t1, 0.0, 0.0)]


BEARINGS = [30.0, -30.0]


def test_winner_faced():
    chk = check_robot(1, 'winner', 2, 9.5, 9.0, math.inf, turn(-30.0),
                      commands(), BEARINGS)
    assert chk.ok, chk.problems
    assert chk.error == pytest.approx(0.0, abs=1e-6)
    assert chk.gesture_latency == pytest.approx(0.5)
    assert 'faced participant 2' in chk.verdict


def test_winner_missed_and_tolerance():
    chk = check_robot(1, 'winner', 1, 9.5, 9.0, math.inf, turn(12.0),
                      commands(), BEARINGS)
    assert chk.ok is False and 'off by 18.0 deg' in chk.verdict
    assert check_robot(1, 'winner', 1, 9.5, 9.0, math.inf, turn(12.0),
                       commands(), BEARINGS, tolerance=20.0).ok


def test_target_from_where_the_robot_stands():
    # 1 m forward of the start, a participant 1.5 m away at +30 deg is at
    # atan2(0.75, 1.299 - 1.0) = 68.3 deg.
    ps = poses([odom(t * 0.1, 0.0 if t < 5 else 1.0, 0.0,
                     0.0 if t < 50 else 68.3) for t in range(100)])
    chk = check_robot(1, 'winner', 1, 1.0, 0.6, math.inf, ps,
                      [cmd(4.0, 0.0, 0.5), cmd(6.0, 0.0, 0.0)], BEARINGS,
                      distance=1.5)
    assert chk.target == pytest.approx(68.3, abs=0.1)
    assert chk.ok


def test_no_gesture_is_a_failure():
    chk = check_robot(1, 'winner', 1, 9.5, 9.0, math.inf, turn(0.0), [],
                      BEARINGS)
    assert chk.ok is False
    assert any('no gesture' in p for p in chk.problems)


@pytest.mark.parametrize('outcome', ['no_winner', 'tie', 'aborted'])
def test_still_when_there_is_no_winner(outcome):
    assert check_robot(1, outcome, 0, 9.5, 9.0, math.inf, turn(0.0),
                       [cmd(9.2, 0.0, 0.0)], BEARINGS).ok
    chk = check_robot(1, outcome, 0, 9.5, 9.0, math.inf, turn(25.0),
                      commands(), BEARINGS)
    assert chk.ok is False
    assert 'moved' in chk.verdict


def test_motion_before_the_window_end_or_after_the_next_round_counts_not():
    # Turned during the window (ends at 9.0, at rest from 8.0) and in the
    # next round (from 15.0): nothing in between.
    def yaw(t):
        return 20.0 * min(1.0, max(0.0, t - 7.0)) + (20.0 if t > 16 else 0)
    ps = poses([odom(k * 0.02, 0.0, 0.0, yaw(k * 0.02)) for k in range(1000)])
    assert check_robot(1, 'no_winner', 0, 9.5, 9.0, 15.0, ps,
                       [cmd(7.5, 0.0, 0.3), cmd(16.0, 0.0, 1.0)],
                       BEARINGS).ok
    assert not check_robot(1, 'no_winner', 0, 9.5, 9.0, 17.0, ps,
                           [cmd(16.0, 0.0, 1.0)], BEARINGS).ok


def test_cut_off_gesture_cannot_be_judged():
    chk = check_robot(1, 'winner', 1, 9.5, 9.0, math.inf, turn(15.0),
                      commands()[:-1], BEARINGS)
    assert chk.ok is None and 'cut off' in chk.verdict


def test_no_odometry():
    chk = check_robot(1, 'winner', 1, 9.5, 9.0, math.inf, [], commands(),
                      BEARINGS)
    assert chk.ok is None and 'no odometry' in chk.verdict


def test_bag_clock_maps_both_ways():
    state = NS(ok=True, offset=0.5, drift=1e-4, local_ref=100.0)
    clock = BagClock([NS(t=99.0, msg=state)])
    assert clock.to_global(100.0) == pytest.approx(100.5)
    assert clock.to_global(110.0) == pytest.approx(110.501)
    assert clock.to_bag(clock.to_global(123.0)) == pytest.approx(123.0)
    assert BagClock([]).to_global(5.0) == 5.0
