"""The fusion demo's scoring against the motion rendered (fusion/truth.py)."""
import math

import numpy as np
import pytest

from hri_sync.dance_off.joints import INDEX
from hri_sync.dance_off.motion import Motion
from hri_sync.fusion.truth import (
    PROFILED, Body, TruthScore, rules_line, table, world_motion)

EPOCH = 1000.0


def walking_motion():
    """Every joint 1 m/s along the sensor's x, 10 s, 100 Hz, looping."""
    times = np.arange(1001) / 100.0
    rng = np.random.default_rng(5)
    pose = rng.normal(0, 0.3, (15, 3))
    positions = pose[None] + times[:, None, None] * np.array([1.0, 0, 0])
    return Motion(times, positions, name='walk')


def score(since=1.0, seconds=5.0):
    return TruthScore(walking_motion(), EPOCH, since, seconds)


def test_world_motion_puts_the_mean_torso_at_the_origin_feet_up():
    world = world_motion(walking_motion())
    torso = world.positions[:, INDEX['torso']].mean(axis=0)
    assert np.allclose(torso[:2], 0.0, atol=1e-9)
    # the sensor's x (its right) is world y; height is z, the floor 1 m down
    assert np.allclose(np.diff(world.positions[:, 0, 1]), 0.01)


def test_a_body_at_the_truth_scores_zero_and_one_off_by_its_offset():
    s = score()
    for k in range(10):
        stamp = EPOCH + 2.0 + k * 0.1
        truth = s.truth_at(stamp)
        s.add('exact', stamp, [Body(truth, np.ones(15))], 0.05)
        s.add('off', stamp, [Body(truth + [0.0, 0.1, 0.0], np.ones(15))],
              0.08)
    out = s.summary()
    assert out['exact']['mean_m'] == 0.0
    assert out['off']['mean_m'] == pytest.approx(0.1)
    assert out['off']['latency_p95_ms'] == pytest.approx(80.0)
    assert out['exact']['instants'] == 10 and out['exact']['joints'] == 150


def test_the_truth_is_read_at_the_stamp_so_a_late_stamp_costs_its_speed():
    s = score()
    for k in range(10):
        stamp = EPOCH + 2.0 + k * 0.1
        late = s.truth_at(stamp - 0.05)     # what was there 50 ms before
        s.add('late', stamp, [Body(late, np.ones(15))], 0.0)
    assert s.summary()['late']['mean_m'] == pytest.approx(0.05)


def test_only_the_scored_time_counts_and_done_after_it():
    s = score(since=1.0, seconds=5.0)
    s.add('v', EPOCH + 0.5, [Body(s.truth_at(EPOCH + 0.5), np.ones(15))], 0)
    s.add('v', EPOCH + 6.5, [Body(s.truth_at(EPOCH + 6.5), np.ones(15))], 0)
    assert s.summary()['v']['instants'] == 0
    assert math.isnan(s.summary()['v']['mean_m'])
    assert not s.done(EPOCH + 5.9) and s.done(EPOCH + 6.0)


def test_a_body_elsewhere_is_nobody_and_joints_not_given_are_left_out():
    s = score()
    stamp = EPOCH + 3.0
    truth = s.truth_at(stamp)
    ghost = Body(truth + [2.0, 0.0, 0.0], np.ones(15))
    confidence = np.ones(15)
    confidence[:5] = 0.0
    partial = truth.copy()
    partial[5] = np.nan
    s.add('v', stamp, [ghost, Body(partial, confidence)], 0.0)
    s.add('w', stamp, [ghost], 0.0)
    out = s.summary()
    assert out['v']['others'] == 1 and out['v']['joints'] == 9
    assert out['w']['others'] == 1 and out['w']['joints'] == 0


def test_bound_coverage_counts_the_truth_inside_each_joints_bound():
    s = score()
    stamp = EPOCH + 3.0
    truth = s.truth_at(stamp)
    bound = np.full(15, 0.2)
    bound[:3] = 0.05            # 3 of 15 too tight for a 0.1 m error
    s.add('fused', stamp, [Body(truth + [0.1, 0, 0], np.ones(15), bound)], 0)
    assert s.summary()['fused']['bound_coverage'] == pytest.approx(12 / 15)


def test_the_table_compares_the_fused_body_with_the_best_profiled_view():
    rows = {'left': 0.10, 'left' + PROFILED: 0.08, 'right' + PROFILED: 0.09,
            'fused': 0.06}
    summary = {k: {'mean_m': v, 'p95_m': 2 * v, 'instants': 10, 'others': 0,
                   'latency_p95_ms': 50.0} for k, v in rows.items()}
    summary['fused'].update(bound_coverage=0.96, latency_p95_ms=90.0)
    last = table(summary, 'fused')[-1]
    assert '25.0 % below the best view (left profiled, 0.080 m)' in last
    assert '96.0 %' in last and '40.0 ms beyond' in last
    assert 'nothing received' in table({}, 'fused')[-1]


def test_the_side_rules_counts_per_view():
    line = rules_line({'right': {'turned to the head': '0'},
                       'left': {'turned to the hands': '3',
                                'turned to the head': '12'}})
    assert line.endswith('left: turned to the hands 3, turned to the head '
                         '12; right: turned to the head 0')
    assert 'no view status' in rules_line({})


def test_the_fused_latency_after_the_newest_capture_it_used():
    # A fused body published 0.12 s after its instant, from captures up to
    # 0.07 s after it, is 0.05 s after its newest capture; the table gives
    # both beyond the slowest view's (50 ms), and a view has neither.
    s = score()
    stamp = EPOCH + 3.0
    body = Body(s.truth_at(stamp), np.ones(15), np.full(15, 0.2), 0.07)
    s.add('fused', stamp, [body], 0.12)
    s.add('left', stamp, [Body(s.truth_at(stamp) + 0.1, np.ones(15))], 0.05)
    summary = s.summary()
    assert summary['fused']['latency_newest_p95_ms'] == pytest.approx(50.0)
    assert 'latency_newest_p95_ms' not in summary['left']
    last = table(summary, 'fused')[-1]
    assert '70.0 ms beyond the slowest view\'s after the instant' in last
    assert '0.0 ms after the newest capture used' in last
    summary['fused']['fusion_node_latency_p95_ms'] = 12.0
    assert "the fusion node's own latency p95 12.0 ms" in table(
        summary, 'fused')[-1]
