"""hri_sync.tools.unison: start skew across robots, heading agreement."""
import math

import pytest

from hri_sync.tools.unison import (distribution, heading_at,
                                   heading_spreads, spread, start_skews)


def test_start_skews_per_round_and_missing_robots():
    starts = {1: {'r1': 10.0, 'r2': 10.0004, 'r3': 9.9999},
              2: {'r1': 20.0, 'r3': 20.001},
              3: {'r1': 30.0, 'r2': math.nan, 'r3': 30.0}}
    skews, missing = start_skews(starts, ['r1', 'r2', 'r3'])
    assert skews == {1: pytest.approx(0.0005)}
    assert missing == {2: ['r2'], 3: ['r2']}


def test_heading_at_interpolates_the_short_way_round():
    track = [(0.0, 0.0), (1.0, 1.0), (2.0, math.pi - 0.1),
             (3.0, -math.pi + 0.1)]
    assert heading_at(track, 0.5) == pytest.approx(0.5)
    assert heading_at(track, 1.0) == 1.0
    # across +-pi: through pi, not back through 0
    assert abs(heading_at(track, 2.5)) == pytest.approx(math.pi, abs=1e-9)
    assert heading_at(track, -0.1) is None
    assert heading_at(track, 3.1) is None


def test_spread_is_the_largest_wrapped_difference():
    assert spread([0.1]) == 0.0
    assert spread([0.1, -0.2, 0.05]) == pytest.approx(0.3)
    assert spread([math.pi - 0.01, -math.pi + 0.01]) == pytest.approx(0.02)


def test_heading_spreads_of_a_lagging_robot():
    """Robot b turns like a, 10 ms later: the spread is the turn rate
    times the lag while turning, zero at rest."""
    rate = 2.0              # rad/s for 1 s from t=1
    def track(lag):
        return [(t / 100.0, rate * min(max(t / 100.0 - 1.0 - lag, 0.0), 1.0))
                for t in range(0, 301)]
    spreads = heading_spreads({'a': track(0.0), 'b': track(0.01)}, 0.0, 3.0)
    assert len(spreads) == 151
    assert max(spreads) == pytest.approx(rate * 0.01, rel=1e-6)
    assert spreads[0] == 0.0 and spreads[-1] == pytest.approx(0.0)
    # a robot without poses at some instants leaves them out
    short = {'a': track(0.0), 'b': [p for p in track(0.0) if p[0] >= 1.0]}
    assert len(heading_spreads(short, 0.0, 3.0)) == 101


def test_distribution_scales_and_counts():
    d = distribution([0.001, 0.002, math.nan, 0.003], 1e3)
    assert d['n'] == 3
    assert d['p50_ms'] == pytest.approx(2.0)
    assert d['max_ms'] == pytest.approx(3.0)
    d = distribution([], unit='deg')
    assert d['n'] == 0 and math.isnan(d['p99_deg'])
