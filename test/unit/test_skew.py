"""hri_sync.clock.skew: clock errors from true-time samples, start skew,
percentiles."""

import math

import pytest

from hri_sync.clock.skew import (ClientTiming, client_timing, percentiles,
                                 start_skew)


def test_clock_error_is_the_minimum_over_the_first_samples():
    # (global stamp, true time, index); the error is stamp - true, the
    # least-delayed of the first ``head`` samples by true time.
    kept = [(10.5 + 0.003, 10.5, 12),     # 3 ms
            (10.0 + 0.002, 10.0, 2),      # 2 ms, first by true time
            (10.25 + 0.0015, 10.25, 7),   # 1.5 ms: the minimum
            (11.0 - 0.5, 11.0, 20)]       # outside head=3: ignored
    t = client_timing('a', kept, head=3)
    assert t.client_id == 'a' and t.first_index == 2 and t.samples == 4
    assert t.clock_error == pytest.approx(0.0015, abs=1e-12)


def test_clock_error_at_the_end_uses_the_last_samples():
    kept = [(10.0 + 0.004, 10.0, 2),      # outside the last head=2
            (10.5 + 0.003, 10.5, 12),     # 3 ms
            (11.0 + 0.0025, 11.0, 20)]    # 2.5 ms: the minimum
    t = client_timing('a', kept, head=2, at_end=True)
    assert t.first_index == 2
    assert t.clock_error == pytest.approx(0.0025, abs=1e-12)


def test_no_samples_kept():
    t = client_timing('b', [])
    assert (t.first_index, t.samples) == (-1, 0)
    assert math.isnan(t.clock_error)


def test_start_skew_is_the_spread_of_clock_errors():
    ts = [ClientTiming('a', 0, 0.0015, 10), ClientTiming('b', 0, -0.0005, 10),
          ClientTiming('c', 0, 0.001, 10), ClientTiming('d', -1, math.nan, 0)]
    assert start_skew(ts) == pytest.approx(0.002, abs=1e-15)


def test_start_skew_needs_two_clients_with_samples():
    assert math.isnan(start_skew([ClientTiming('a', 0, 0.001, 1),
                                  ClientTiming('b', -1, math.nan, 0)]))
    assert math.isnan(start_skew([]))


def test_percentiles_nearest_rank():
    vals = list(range(100, 0, -1))           # 1..100, any order
    assert percentiles(vals) == {'p50': 50, 'p99': 99, 'max': 100}
    assert percentiles([3.0, math.nan, 1.0, 2.0], qs=(50, 100)) == {
        'p50': 2.0, 'p100': 3.0, 'max': 3.0}
    assert percentiles([7.0]) == {'p50': 7.0, 'p99': 7.0, 'max': 7.0}


def test_percentiles_of_nothing_are_nan():
    out = percentiles([math.nan])
    assert set(out) == {'p50', 'p99', 'max'}
    assert all(math.isnan(v) for v in out.values())
