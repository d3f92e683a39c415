"""bench/lsl_compare.py's LSL figures (hri_sync_support.lsl_bench) on a
made-up recording: a remote clock 300 ppm fast, LSL estimates every 2 s."""
import math
import os
import sys
from types import SimpleNamespace as NS

import pytest

sys.path.insert(0, os.path.join(os.path.dirname(__file__), '..', '..',
                                'support'))
pytest.importorskip('pylsl')
from hri_sync_support import lsl_bench  # noqa: E402

DRIFT, OFFSET = 3e-4, -5.0


def remote(true):
    """The remote LSL clock at true (= recorder) time."""
    return true + OFFSET + DRIFT * (true - 100.0)


def stream():
    """A stream's estimates (exact, every 2 s) and 20 Hz samples, each
    mapped with the latest estimate as LSL's docs show."""
    estimates = [(t, t - remote(t), 7e-5) for t in range(100, 141, 2)]
    samples = []
    for k in range(800):
        true = 100.0 + k * 0.05
        latest = [e for e in estimates if e[0] <= true][-1][1]
        samples.append((remote(true), true, latest, true - remote(true)))
    return NS(estimates=estimates, samples=samples, preempted=0)


def test_docs_method_lags_the_drift_and_the_fit_does_not():
    rec = NS(streams={'c1': stream(), 'c2': stream()}, error=None)
    out = lsl_bench.figures(rec, 0.0, 100.0, [105.5, 111.9, 121.0])
    # Up to 2 s old: 300 ppm * 2 s = 0.6 ms.
    assert 0.55 < out['docs']['sample_error_ms']['max'] <= 0.6
    assert out['drift_fit']['sample_error_ms']['max'] < 1e-6
    # Placed at the stamp + the latest correction: 0.6 ms * 300 ppm off.
    assert out['online_fit']['sample_error_ms']['max'] < 1e-3
    # Both clients the same: they agree exactly, whatever their error.
    assert out['docs']['clock_skew_ms']['p99'] == 0.0
    assert out['docs']['clock_error_at_starts_ms']['max'] == \
        pytest.approx(0.57, abs=0.02)


def test_a_window_start_without_a_sample_near_it_is_left_out():
    assert math.isnan(lsl_bench.at([(100.0, 1e-3)], 100.5))
    assert lsl_bench.at([(100.0, 1e-3), (100.5, 2e-3)], 100.4) == 2e-3
