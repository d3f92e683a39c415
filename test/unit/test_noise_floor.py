"""The noise floor: the jitter floor of a window, the quiet baseline, and
the decision module's noise rule (deterministic, seeded)."""
import math

import numpy as np
import pytest

from hri_sync.dance_off.expressiveness import (RunningExpressiveness,
                                               expressiveness)
from hri_sync.decision.rule import (NO_WINNER, NOISE, TIE, WINNER,
                                    RoundCollector, decide)
from hri_sync.data_process.noise_floor import (QuietBaseline, combine,
                                               valid_floor)
from hri_sync.data_process.processors import Processor, ProcessResult

P = ['left', 'right']


def still(sigma, rate=30.0, dur=10.0, seed=0, joints=15):
    rng = np.random.default_rng(seed)
    n = int(rate * dur)
    t = np.arange(n) / rate
    base = rng.uniform(-1, 1, (1, joints, 3))
    return t, base + rng.normal(0, sigma, (n, joints, 3))


@pytest.mark.parametrize('sigma,rate', [(0.003, 20.0), (0.003, 30.0),
                                        (0.01, 30.0)])
def test_jitter_floor_of_a_still_person_is_its_score(sigma, rate):
    t, pos = still(sigma, rate)
    res = expressiveness(t, pos, duration=10.0)
    # 15 joints x 6 sigma^2 r^2 in expectation; the estimate within 10 %
    assert res.value == pytest.approx(15 * 6 * sigma ** 2 * rate ** 2,
                                      rel=0.05)
    assert res.jitter == pytest.approx(res.value, rel=0.1)


def test_jitter_floor_sees_jitter_not_smooth_motion():
    t, pos = still(0.003, 30.0, seed=1)
    wave = 0.3 * np.sin(2 * np.pi * 0.8 * t)       # a slow gesture, 0.3 m
    moving = pos.copy()
    moving[:, 5:9, 0] += wave[:, None]
    quiet = expressiveness(t, pos, duration=10.0)
    busy = expressiveness(t, moving, duration=10.0)
    assert busy.value > 5 * quiet.value
    assert busy.jitter == pytest.approx(quiet.jitter, rel=0.15)


def test_jitter_floor_with_dropped_frames_and_low_confidence():
    t, pos = still(0.003, 30.0, seed=2)
    keep = np.ones(len(t), bool)
    keep[::7] = False                               # dropped frames
    conf = np.ones(pos.shape[:2])
    conf[::3, 10:] = 0.0                            # lost leg joints
    res = expressiveness(t[keep], pos[keep], conf[keep], duration=10.0)
    assert res.jitter == pytest.approx(res.value, rel=0.15)


def test_jitter_floor_unknown_without_three_new_samples():
    run = RunningExpressiveness(15)
    p = np.zeros((15, 3))
    for k in range(5):                  # a frozen tracker: repeats only
        run.add(k / 30.0, p, np.ones(15))
    res = run.score(1.0)
    assert res.value == 0.0 and math.isnan(res.jitter)


class Level(Processor):
    """Mean of Sample-like values: a level of activity."""

    quiet_baseline = True

    def begin(self, start, end):
        self._v = []

    def add(self, frame):
        self._v.append(frame.msg)

    def result(self):
        return ProcessResult(float(np.mean(self._v)), len(self._v))


def test_quiet_baseline_is_the_quietest_stretch_of_the_span():
    b = QuietBaseline(Level, chunk=1.0, step=0.25, span=30.0)
    assert math.isnan(b.level()[0])
    for k in range(30 * 30):                   # 30 s at 30 Hz
        t = k / 30.0
        b.add(t, 0.2 if 5 <= t < 7 else 1.0)   # quiet from 5 to 7 s
    level, n = b.level()
    assert level == pytest.approx(0.2) and n > 50
    for k in range(30 * 30, 30 * 60):          # the quiet stretch ages out
        b.add(k / 30.0, 1.0)
    assert b.level()[0] == pytest.approx(1.0)


def test_quiet_baseline_skips_a_silent_stretch_and_old_stamps():
    b = QuietBaseline(Level, chunk=1.0, step=0.25, span=60.0)
    for t in np.arange(0, 3, 1 / 30.0):
        b.add(t, 1.0)
    b.add(1.0, 0.0)                            # earlier: ignored
    b.add(10.0, 0.0)                           # after 7 s of silence
    b.add(12.0, 0.0)
    assert b.level()[0] == pytest.approx(1.0)


def test_combine_and_validation():
    assert combine(0.1, 0.3) == 0.3
    assert combine(math.nan, 0.3) == 0.3
    assert combine(-1.0, math.inf, 0.2) == 0.2
    assert math.isnan(combine(math.nan, -0.5))
    assert not valid_floor('x') and not valid_floor(-0.1)
    assert valid_floor(0.0)


def noise(left, right, **kw):
    return decide(P, {'left': ('ok',) + left, 'right': ('ok',) + right},
                  rule=NOISE, **kw)


def test_noise_rule_winner_names_the_floors():
    v = noise((2.9, 0.18), (0.055, 0.033))
    assert (v.outcome, v.winner) == (WINNER, 1)
    assert 'its noise floor 0.18' in v.reason
    assert v.noise_floors == [0.18, 0.033]


def test_noise_rule_best_not_above_factor_times_its_floor():
    v = noise((0.09, 0.033), (0.05, 0.033))
    assert (v.outcome, v.winner) == (NO_WINNER, 0)
    assert 'within noise' in v.reason and '3 x its noise floor' in v.reason
    assert (noise((0.09, 0.033), (0.0, 0.0), noise_factor=2.0).outcome
            == WINNER)


def test_noise_rule_runner_up_within_combined_noise():
    # 1.0 - 0.8 = 0.2 <= hypot(0.15, 0.15) = 0.212
    v = noise((1.0, 0.15), (0.8, 0.15))
    assert v.outcome == NO_WINNER
    assert 'within noise' in v.reason and 'combined noise 0.2121' in v.reason
    assert noise((1.0, 0.1), (0.8, 0.1)).outcome == WINNER   # 0.2 > 0.141


def test_noise_rule_unknown_floor_falls_back_to_threshold():
    v = noise((0.5, math.nan), (0.1, 0.01), min_value=1.0)
    assert v.outcome == NO_WINNER
    assert 'noise floor of left unknown' in v.reason
    assert 'min_expressiveness 1' in v.reason
    v = noise((2.0, -1.0), (1.9, 0.01), min_value=1.0, tie_margin=0.2)
    assert v.outcome == TIE             # threshold rule: within tie_margin
    v = noise((2.0, 0.1), (1.0, math.inf), min_value=1.0)
    assert (v.outcome, v.winner) == (WINNER, 1)
    assert 'noise floor of right unknown: tie_margin rule' in v.reason
    assert math.isnan(v.noise_floors[1])


def test_threshold_rule_ignores_noise_floors():
    v = decide(P, {'left': ('ok', 0.09, 0.033), 'right': ('ok', 0.05, 0.03)})
    assert (v.outcome, v.winner) == (WINNER, 1)


def test_bad_rule_or_factor_rejected():
    with pytest.raises(ValueError):
        decide(P, {}, rule='loudest')
    with pytest.raises(ValueError):
        decide(P, {}, rule=NOISE, noise_factor=-1.0)
    with pytest.raises(ValueError):
        RoundCollector(P, 1.0, rule='x')


def test_collector_counts_unknown_noise_floors():
    c = RoundCollector(P, 1.0, rule=NOISE)
    c.open(1, 10.0)
    c.add(1, 'left', 'ok', 2.0, 0.001, math.nan)
    closed, _ = c.add(1, 'right', 'ok', 0.05, 0.001, -0.2)
    assert dict(c.noise_unknown) == {'left': 1, 'right': 1}
    assert closed.verdict.outcome == WINNER          # 2.0 >= min_value 0
    assert 'noise floor of left unknown' in closed.verdict.reason
    c.open(2, 20.0)
    c.add(2, 'left', 'ok', 0.06, 0.001, 0.033)
    closed, _ = c.add(2, 'right', 'ok', 0.05, 0.001, 0.033)
    assert closed.verdict.outcome == NO_WINNER
    assert 'within noise' in closed.verdict.reason


def test_quiet_stretches_of_the_skeleton_processor_skip_the_jitter_floor():
    from types import SimpleNamespace as NS
    from hri_sync.dance_off.expressiveness import SkeletonExpressiveness
    from hri_sync.data_process.processors import Frame
    t, pos = still(0.003, seed=2, dur=2.0)
    frames = [Frame(s, NS(positions=[NS(x=x, y=y, z=z) for x, y, z in p],
                          confidence=[0.9] * 15, user_id=1))
              for s, p in zip(t, pos)]
    full, quiet = SkeletonExpressiveness(), SkeletonExpressiveness()
    full.begin(0.0, 2.0)
    quiet.begin_quiet(0.0, 2.0)
    for f in frames:
        full.add(f)
        quiet.add(f)
    a, b = full.result(), quiet.result()
    assert a.value == b.value and a.value > 0       # the same score
    assert a.noise_floor > 0 and math.isnan(b.noise_floor)
    stretches = []

    class Seen(Level):
        def begin_quiet(self, start, end):
            stretches.append((start, end))
            super().begin_quiet(start, end)
    base = QuietBaseline(Seen, chunk=1.0, step=0.25, span=30.0)
    for s in t:
        base.add(s, 1.0)
    assert stretches[:2] == [(0.0, 1.0), (0.25, 1.25)]
