"""The device clock map's shared test vectors (test/data/clock_map/).

The gtest DeviceClock.SharedVectorsMeetPythonsBounds replays the same
streams through the C++ tracker's map with the same bounds;
scripts/make_clock_map_vectors.py made them.
"""
import csv
import math
import os

import pytest

from hri_sync.data_process.mapping import DeviceClockMapper

VECTORS = os.path.join(os.path.dirname(os.path.dirname(__file__)), 'data',
                       'clock_map')
# The vectors' ``mapped`` column is this Python map's output; a different
# result means the algorithm changed: re-run the script (the C++ must follow).
AGREE = 10e-6
# A map is a lower envelope: never later than the arrival (float rounding).
ENVELOPE_SLACK = 1e-6


def cases():
    with open(os.path.join(VECTORS, 'cases.csv')) as f:
        return list(csv.DictReader(f))


def rows(name):
    with open(os.path.join(VECTORS, name + '.csv')) as f:
        return [(float(r['device']), float(r['arrival']), float(r['true']),
                 float(r['mapped']) if r['mapped'] else None)
                for r in csv.DictReader(f)]


def test_every_case_has_its_stream():
    names = [c['name'] for c in cases()]
    assert names == ['steady', 'drifting', 'reader_stall', 'clock_reset',
                     'jitter']
    for name in names:
        assert len(rows(name)) > 500


@pytest.mark.parametrize('case', cases(), ids=lambda c: c['name'])
def test_python_map_meets_the_vectors_bounds(case):
    m = DeviceClockMapper()
    fit_start, prev = None, None
    worst = worst_settled = 0.0
    for device, arrival, true, mapped in rows(case['name']):
        if prev is None or device < prev:
            fit_start = device                  # a new fit (first or reset)
        prev = device
        m.observe(device, arrival)
        assert m.ready == (mapped is not None), (device, mapped)
        if not m.ready:
            continue
        g = m.to_global(device)
        assert g == pytest.approx(mapped, abs=AGREE), (
            'the Python map no longer gives the vectors\' mapped column: '
            're-run scripts/make_clock_map_vectors.py')
        assert g <= arrival + ENVELOPE_SLACK
        err = abs(g - true)
        worst = max(worst, err)
        if device - fit_start >= float(case['skip_s']):
            worst_settled = max(worst_settled, err)
    assert m.resets == int(case['resets'])
    assert worst_settled < float(case['bound_ms']) * 1e-3
    assert worst < float(case['settle_bound_ms']) * 1e-3
    assert math.isfinite(m.drift)
