"""The tracker filter's lag, joint by joint (hri_sync.fusion.lag)."""
import math

import numpy as np
import pytest

from hri_sync.fusion.lag import FilterLag, FilterParams
from hri_sync.fusion.pipeline import Fusion
from hri_sync.fusion.profile import Profile, timing_spread
from test_fusion_core import body
from test_fusion_wrong_pose import POSES

RATE = 30.0


def one_euro(samples, p=FilterParams()):
    """The tracker's filter (src/tracker/joint_filter.cpp) on ``samples``
    [(t, (joints, 3))]: its outputs."""
    out, history, speed, x = [], [], 0.0, None
    for t, pos in samples:
        if x is None:
            x, last = pos.copy(), t
            history.append((t, pos))
            out.append(x.copy())
            continue
        dt, last = t - last, t
        history.append((t, pos))
        while len(history) > 2 and history[0][0] < t - 2 * p.block - 1e-9:
            history.pop(0)
        new = [(s, q) for s, q in history if s > t - p.block]
        old = [(s, q) for s, q in history if s <= t - p.block]
        if old:
            v = np.linalg.norm(np.mean([q for _, q in new], axis=0)
                               - np.mean([q for _, q in old], axis=0),
                               axis=1) / (np.mean([s for s, _ in new])
                                          - np.mean([s for s, _ in old]))
        else:
            v = np.linalg.norm(pos - x, axis=1) / dt

        def alpha(c):
            return 1 / (1 + 1 / (2 * math.pi * c * dt))
        speed = alpha(p.speed_cutoff) * v + (1 - alpha(p.speed_cutoff)) * speed
        a = alpha(p.min_cutoff + p.beta * np.maximum(speed - p.dead_zone, 0))
        x = a[:, None] * pos + (1 - a[:, None]) * x
        out.append(x.copy())
    return out


def moving(speeds, seconds=3.0):
    """Joints moving along x at ``speeds`` (m/s), sampled at RATE: the
    sample times and the true positions."""
    t = np.arange(int(seconds * RATE)) / RATE
    return t, [np.outer(speeds, [tk, 0, 0]) for tk in t]


def test_each_joint_is_redated_by_its_own_lag():
    # Three joints at 0.8, 1.5 and 3 m/s through the tracker's filter lag
    # by about 1 / (2 pi f): 69, 31 and 15 ms. One delay for all (40 ms)
    # leaves them 2.3, 1.4 and 7.6 cm off the body 40 ms before each
    # capture; re-dated, each is within 3 mm of it.
    speeds = np.array([0.8, 1.5, 3.0])
    t, truth = moving(speeds)
    filtered = one_euro(list(zip(t, truth)))
    lag = FilterLag(FilterParams(), delay=0.04)
    out = [lag.redate(tk, f) for tk, f in zip(t, filtered)]
    settled = t >= 1.5
    want = np.array([np.outer(speeds, [tk - 0.04, 0, 0]) for tk in t])
    before = np.abs(np.array(filtered) - want)[settled][..., 0].max(axis=0)
    after = np.abs(np.array(out) - want)[settled][..., 0].max(axis=0)
    assert before == pytest.approx([0.023, 0.014, 0.076], abs=0.003)
    assert (after < 0.003).all(), after
    assert lag.lags() == pytest.approx(
        [1 / (2 * math.pi * (0.3 + 4 * (s - 0.3))) for s in speeds],
        rel=0.05)


def test_a_slow_joints_lag_is_capped():
    lag = FilterLag(FilterParams(), delay=0.04)
    t, truth = moving(np.array([0.0, 0.2]))
    for tk, p in zip(t, truth):
        lag.redate(tk, p)
    assert lag.lags() == pytest.approx([0.07, 0.07])


def test_a_jump_a_gap_a_repeated_or_late_stamp_is_not_moved():
    lag = FilterLag(FilterParams(), delay=0.04)
    t, truth = moving(np.array([2.0]), seconds=1.0)
    for tk, p in zip(t, truth):
        lag.redate(tk, p)
    step = t[-1] + 1 / RATE
    jumped = truth[-1] + [[0.5, 0, 0]]          # 15 m/s: the tracker jumped
    assert (lag.redate(step, jumped) == jumped).all()
    speed = lag.speed.copy()
    assert (lag.redate(step, jumped + 1) == jumped + 1).all()   # repeated
    assert (lag.redate(step - 0.1, jumped) == jumped).all()     # late
    assert (lag.speed == speed).all()
    later = jumped + [[0.02, 0, 0]]
    assert (lag.redate(step + 0.5, later) == later).all()       # a gap
    assert (lag.speed == 0).all()
    nan = np.array([[np.nan, np.nan, np.nan]])
    assert np.isnan(lag.redate(step + 0.5 + 1 / RATE, nan)).all()


def test_a_profiles_filter_round_trips_and_bad_values_are_refused():
    profile = Profile(delay=0.04, filter=FilterParams())
    again = Profile.from_dict(profile.to_dict())
    assert again.filter == profile.filter
    assert isinstance(again.filter_lag(), FilterLag)
    assert Profile().filter_lag() is None
    for bad in ({'max_lag': -1}, {'beta': 'x'}, {'cutoff': 1.0}, [0.3]):
        with pytest.raises(ValueError):
            Profile.from_dict({'filter': bad})


def test_the_fusion_redates_each_views_skeletons():
    # The views see a body walking at 1.5 m/s through the tracker's
    # filter: with the filter in the profile the fused body is where the
    # body was, with one delay 1.4 cm behind.
    t, _ = moving(np.zeros(1))
    truth = [body(1.5 * tk - 2.0) for tk in t]
    filtered = one_euro(list(zip(t, truth)))
    errors = []
    for params in (None, FilterParams()):
        profile = Profile(delay=0.04, filter=params)
        clock = {'now': 0.0}
        fusion = Fusion(POSES, None, lambda: clock['now'],
                        {v: profile for v in POSES})
        frames = []
        for tk, f in zip(t, filtered):
            clock['now'] = tk + 0.05
            for view, pose in POSES.items():
                fusion.add(view, 1, tk, pose.from_world(f),
                           np.full(15, 0.9), 0.001)
            frames += fusion.poll()
        late = [f for f in frames if f.stamp >= 1.5 and f.people]
        assert len(late) > 20
        errors.append(max(np.abs(f.people[0].body.positions
                                 - body(1.5 * f.stamp - 2.0)).max()
                          for f in late))
    assert errors[0] == pytest.approx(0.014, abs=0.002)
    assert errors[1] < 0.003, errors


def test_the_timing_spread_is_the_error_that_grows_with_speed():
    # Views dated with a 10 ms (one sigma) timing error, beside 2 cm of
    # noise that does not grow with speed: the spread is 1.96 * 10 ms.
    rng = np.random.default_rng(3)
    velocity = rng.normal(0, 1.5, (400, 15, 3))
    dt = rng.normal(0, 0.01, (4, 400, 15, 1))
    errors = dt * velocity + rng.normal(0, 0.02, (4, 400, 15, 3))
    assert timing_spread(errors, velocity) == pytest.approx(0.0196, rel=0.1)
    assert timing_spread(rng.normal(0, 0.02, (4, 400, 15, 3)),
                         velocity) < 0.004
