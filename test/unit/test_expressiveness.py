"""Expressiveness against hand-computed cases."""

import numpy as np
import pytest

from hri_sync.dance_off.expressiveness import (RunningExpressiveness,
                                               expressiveness)


def track(xs, joints=1):
    """Positions (N, joints, 3) moving along x by the given values."""
    pos = np.zeros((len(xs), joints, 3))
    pos[:, :, 0] = np.asarray(xs, dtype=float)[:, None]
    return pos


def test_constant_step():
    # 0.1 m per 0.1 s: each term 0.1**2 / 0.1 = 0.1; two terms; T = 1 s.
    res = expressiveness([0.0, 0.1, 0.2], track([0.0, 0.1, 0.2]), duration=1.0)
    assert res.value == pytest.approx(0.2)
    assert (res.frames_used, res.frames_rejected, res.terms) == (3, 0, 2)


def test_default_duration_is_stamp_span():
    res = expressiveness([0.0, 0.1, 0.2], track([0.0, 0.1, 0.2]))
    assert res.duration == pytest.approx(0.2)
    assert res.value == pytest.approx(1.0)      # (0.1 + 0.1) / 0.2


def test_dropped_frame_widens_gap():
    # 1 m/s with the 0.2 s frame missing: 0.01/0.1 + 0.04/0.2 = 0.3 over 0.3 s
    res = expressiveness([0.0, 0.1, 0.3], track([0.0, 0.1, 0.3]), duration=0.3)
    assert res.value == pytest.approx(1.0)


@pytest.mark.parametrize('rate', [20.0, 30.0, 60.0])
def test_rate_independent_for_smooth_motion(rate):
    # Three joints at 0.5, 1 and 2 m/s: sum of squared speeds = 5.25.
    t = np.arange(0, 2.0 + 1e-9, 1.0 / rate)
    pos = np.zeros((len(t), 3, 3))
    pos[:, 0, 0] = 0.5 * t
    pos[:, 1, 1] = 1.0 * t
    pos[:, 2, 2] = 2.0 * t
    res = expressiveness(t, pos, duration=t[-1] - t[0])
    assert res.value == pytest.approx(5.25)


def test_diagonal_displacement_uses_euclidean_distance():
    pos = np.zeros((2, 1, 3))
    pos[1, 0] = [0.3, 0.4, 0.0]                 # 0.5 m in 0.5 s
    res = expressiveness([0.0, 0.5], pos, duration=2.0)
    assert res.value == pytest.approx(0.25 / 0.5 / 2.0)


def test_nan_joint_is_rejected_counted_and_bridged():
    # Joint 0 steps 0.1 m per 0.1 s; joint 1 is NaN at frame 1, so its
    # frame-2 sample pairs with frame 0: 0.2**2 / 0.2 = 0.2.
    pos = track([0.0, 0.1, 0.2], joints=2)
    pos[1, 1, 2] = np.nan
    res = expressiveness([0.0, 0.1, 0.2], pos, duration=1.0)
    assert res.value == pytest.approx(0.1 + 0.1 + 0.2)
    assert res.nonfinite_joints == 1
    assert res.frames_rejected == 0
    assert res.terms == 3


def test_infinite_and_all_bad_frames():
    pos = track([0.0, 0.1, 0.2, 0.3])
    pos[1, 0, 0] = np.inf
    pos[2, 0, 1] = -np.inf
    res = expressiveness([0.0, 0.1, 0.2, 0.3], pos, duration=1.0)
    assert res.nonfinite_joints == 2
    assert res.frames_rejected == 2
    assert res.frames_used == 2
    assert res.value == pytest.approx(0.3 ** 2 / 0.3)
    assert np.isfinite(res.value)


def test_confidence_threshold():
    pos = track([0.0, 0.1, 0.2], joints=2)
    pos[:, 1, 0] *= 10                          # joint 1 moves 1 m per frame
    conf = np.array([[1.0, 0.0], [1.0, 0.0], [1.0, 0.4]])
    res = expressiveness([0.0, 0.1, 0.2], pos, conf, duration=1.0,
                         min_confidence=0.5)
    assert res.value == pytest.approx(0.2)
    assert res.low_confidence_joints == 3
    res = expressiveness([0.0, 0.1, 0.2], pos, conf, duration=1.0,
                         min_confidence=0.0)
    assert res.value == pytest.approx(0.2 + 2 * 1.0 / 0.1)


def test_nan_confidence_is_low():
    conf = np.array([[1.0], [np.nan], [1.0]])
    res = expressiveness([0.0, 0.1, 0.2], track([0.0, 0.1, 0.2]), conf,
                         duration=1.0)
    assert res.low_confidence_joints == 1
    assert res.value == pytest.approx(0.04 / 0.2)


def test_unsorted_and_duplicate_stamps():
    stamps = [0.2, 0.0, 0.1, 0.1]
    pos = track([0.2, 0.0, 0.1, 5.0])           # the duplicate is rejected
    res = expressiveness(stamps, pos, duration=1.0)
    assert res.value == pytest.approx(0.2)
    assert res.frames_rejected == 1


def test_nonfinite_stamp_rejected():
    res = expressiveness([0.0, np.nan, 0.1], track([0.0, 9.0, 0.1]),
                         duration=1.0)
    assert res.frames_rejected == 1
    assert res.value == pytest.approx(0.1)


def test_still_is_zero_and_empty_is_zero():
    res = expressiveness([0.0, 0.1, 0.2], track([1.0, 1.0, 1.0]), duration=1.0)
    assert res.value == 0.0
    res = expressiveness(np.zeros(0), np.zeros((0, 15, 3)), duration=1.0)
    assert (res.value, res.frames_used, res.terms) == (0.0, 0, 0)
    res = expressiveness([0.0], track([1.0]))
    assert res.value == 0.0 and res.duration == 0.0


def test_noise_floor_matches_theory():
    # Still joints with Gaussian noise sigma per axis at rate r:
    # E[d^2] = 6 sigma^2, each term 6 sigma^2 r, r terms per second.
    rng = np.random.default_rng(0)
    rate, sigma, joints = 20.0, 0.003, 15
    t = np.arange(0, 200.0, 1.0 / rate)
    pos = rng.normal(0.0, sigma, (len(t), joints, 3))
    res = expressiveness(t, pos, duration=t[-1] - t[0])
    expected = joints * 6 * sigma ** 2 * rate ** 2
    assert res.value == pytest.approx(expected, rel=0.03)


def test_bad_shapes():
    with pytest.raises(ValueError):
        expressiveness([0.0, 0.1], np.zeros((3, 15, 3)))
    with pytest.raises(ValueError):
        expressiveness([0.0, 0.1], np.zeros((2, 15, 2)))
    with pytest.raises(ValueError):
        expressiveness([0.0, 0.1], np.zeros((2, 15, 3)), np.ones((2, 14)))


def test_running_sum_added_live_equals_the_whole_window():
    # Frames added one by one as they arrive (in stamp order) give the
    # whole-window score, with NaN joints, low confidence and a drop.
    rng = np.random.default_rng(3)
    t = np.delete(np.arange(0.0, 3.0, 0.05), [7, 30])
    pos = rng.normal(0.0, 0.05, (len(t), 4, 3))
    pos[rng.random(pos.shape) < 0.02] = np.nan
    conf = rng.uniform(0.3, 1.0, (len(t), 4))
    run = RunningExpressiveness(4, min_confidence=0.5)
    for k in range(len(t)):
        run.add(float(t[k]), pos[k], conf[k])
    whole = expressiveness(t[::-1], pos[::-1], conf[::-1], duration=3.0)
    assert run.score(3.0) == whole


def test_running_sum_rejects_a_frame_out_of_stamp_order():
    run = RunningExpressiveness(1)
    assert run.add(0.0, track([0.0])[0], np.ones(1))
    assert run.add(0.2, track([0.2])[0], np.ones(1))
    assert not run.add(0.1, track([9.0])[0], np.ones(1))
    assert (run.out_of_order, run.frames_rejected) == (1, 1)
    assert run.score(1.0).value == pytest.approx(0.2)


def test_repeated_frames_are_counted_and_not_paired():
    """A tracker repeating its last skeleton (Kinect v1): the repeats add
    nothing and the next new frame pairs over the real time difference."""
    still = np.zeros((15, 3))
    moved = still.copy()
    moved[0, 0] = 0.1
    stamps = [0.0, 1 / 30, 2 / 30, 3 / 30]
    res = expressiveness(stamps, [still, still, still, moved], duration=1.0)
    assert res.value == pytest.approx(0.01 / (3 / 30))
    assert res.frames_used == 4 and res.frames_rejected == 0
    run = RunningExpressiveness()
    for t, p in zip(stamps, [still, still, still, moved]):
        run.add(t, p, np.ones(15))
    assert run.repeated == 2
