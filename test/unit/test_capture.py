"""hri_sync.timing.capture: the sample buffer, window statistics and the device
clock mapper."""

import math
import random

import pytest

from hri_sync.timing.capture import (DeviceClockMapper, SampleBuffer,
                                     window_stats)

# -- SampleBuffer ------------------------------------------------------------


def stamps_of(frames):
    return [f.stamp for f in frames]


def test_buffer_keeps_only_the_last_keep_seconds():
    b = SampleBuffer(keep=5.0)
    for k in range(11):
        b.add(float(k), 'm%d' % k)
    assert stamps_of(b.take(-math.inf, math.inf)) == [5.0, 6.0, 7.0, 8.0,
                                                      9.0, 10.0]


def test_take_is_half_open_and_sorted_by_stamp():
    b = SampleBuffer(keep=100.0)
    for s in (3.0, 1.0, 2.0, 4.0, 2.5):         # out of order arrivals
        b.add(s, 'm%g' % s)
    frames = b.take(1.0, 3.0)
    assert stamps_of(frames) == [1.0, 2.0, 2.5]
    assert [f.msg for f in frames] == ['m1', 'm2', 'm2.5']


def test_hold_keeps_samples_from_the_window_start_until_released():
    b = SampleBuffer(keep=2.0)
    b.hold(3.0)
    for k in range(11):
        b.add(float(k), k)
    # Without the hold only 8..10 would be left.
    assert stamps_of(b.take(3.0, 7.0)) == [3.0, 4.0, 5.0, 6.0]
    assert stamps_of(b.take(0.0, 3.0)) == []     # before the hold: dropped
    b.release(3.0)
    b.add(11.0, 11)
    assert stamps_of(b.take(-math.inf, math.inf)) == [9.0, 10.0, 11.0]


def test_two_holds_keep_the_earliest_until_both_released():
    b = SampleBuffer(keep=1.0)
    b.hold(2.0)
    b.hold(5.0)
    for k in range(10):
        b.add(float(k), k)
    assert stamps_of(b.take(0.0, 10.0))[0] == 2.0
    b.release(2.0)
    b.add(10.0, 10)
    assert stamps_of(b.take(0.0, 11.0))[0] == 5.0
    b.release(5.0)
    b.add(11.0, 11)
    assert stamps_of(b.take(0.0, 12.0)) == [10.0, 11.0]


# -- window_stats ------------------------------------------------------------

P = 0.0625           # 16 Hz: exact in binary
FIRST = 0.015625


def test_full_window():
    stamps = [FIRST + k * P for k in range(16)]       # all within [0, 1)
    st = window_stats(stamps, 0.0, 1.0)
    assert st == {'coverage': 1.0, 'dropped': 0, 'period': P,
                  'first_frame_offset': FIRST}


def test_gap_counts_dropped_frames_and_uncovered_time():
    stamps = [FIRST + k * P for k in range(16) if k not in (5, 6, 7)]
    st = window_stats(stamps, 0.0, 1.0)
    assert st['dropped'] == 3
    assert st['period'] == P
    # 0.25 s gap uncovered: 12 gaps of P + 0.015625 lead + 0.046875 tail.
    assert st['coverage'] == 0.75
    assert st['first_frame_offset'] == FIRST


def test_sensor_that_stops_half_way():
    stamps = [FIRST + k * P for k in range(8)]
    st = window_stats(stamps, 0.0, 1.0)
    # 7 gaps + the lead; the 0.546875 s tail is uncovered.
    assert st['coverage'] == 7 * P + FIRST
    assert st['dropped'] == 0


def test_late_first_frame_leaves_the_lead_uncovered():
    stamps = [0.5 + k * P for k in range(8)]         # starts at 0.5 s
    st = window_stats(stamps, 0.0, 1.0)
    assert st['first_frame_offset'] == 0.5
    assert st['coverage'] == 7 * P + 0.0625          # + the tail


def test_explicit_max_gap():
    stamps = [FIRST + k * P for k in range(16) if k not in (5, 6, 7)]
    st = window_stats(stamps, 0.0, 1.0, max_gap=0.5)
    assert st['coverage'] == 1.0       # the 0.25 s gap now counts
    assert st['dropped'] == 3


def test_no_samples():
    st = window_stats([], 10.0, 11.0)
    assert st['coverage'] == 0.0 and st['dropped'] == 0
    assert math.isnan(st['period']) and math.isnan(st['first_frame_offset'])


def test_one_sample_does_not_cover_the_window():
    # A sensor that sent one frame and died must not look complete.
    st = window_stats([10.25], 10.0, 70.0)
    assert st['first_frame_offset'] == 0.25
    assert st['dropped'] == 0
    assert st['coverage'] < 0.5


# -- DeviceClockMapper -------------------------------------------------------

def test_mapper_needs_a_sample():
    with pytest.raises(ValueError, match='no sample observed'):
        DeviceClockMapper().to_global(1.0)


def test_mapper_short_span_takes_the_minimum_delay_without_drift():
    m = DeviceClockMapper(min_span=5.0)
    m.observe(10.0, 15.25)
    m.observe(10.5, 15.5)       # the least-delayed sample
    m.observe(11.0, 16.125)
    assert m.offset == 5.0 and m.drift == 0.0
    assert m.to_global(12.0) == 17.0


T0 = 1.7e9


def device_stream(seed, ppm, offset, rate=30.0, dur=40.0,
                  delay=(0.3e-3, 15e-3), t0=T0):
    """(device stamp, global arrival, true time) of a drifting sensor whose
    clock reads ``offset`` at true time ``t0``."""
    rng = random.Random(seed)
    out = []
    for k in range(int(dur * rate)):
        true = t0 + k / rate
        device = offset + (true - t0) * (1.0 + ppm)
        out.append((device, true + rng.uniform(*delay), true))
    return out


@pytest.mark.parametrize('ppm', [100e-6, -100e-6])
@pytest.mark.parametrize('seed', range(4))
def test_mapper_recovers_offset_and_drift_from_delayed_samples(seed, ppm):
    m = DeviceClockMapper(window=30.0, min_span=5.0)
    worst = 0.0
    for device, arrival, true in device_stream(seed, ppm, 1234.5):
        m.observe(device, arrival)
        err = m.to_global(device) - true
        if device - 1234.5 > 5.0:             # past min_span
            worst = max(worst, abs(err))
        # Never later than the arrival: the map is a lower envelope.
        assert m.to_global(device) <= arrival + 1e-6
    # Global = device + offset(device): slope -ppm/(1+ppm).
    assert m.drift == pytest.approx(-ppm / (1 + ppm), abs=20e-6)
    # Bias of the envelope: about the smallest delay (0.3 ms) plus the
    # spacing of the bins' minima; 100 ppm over the 30 s window would be
    # 3 ms without the drift.
    assert worst < 1.5e-3


def test_mapper_without_drift_would_fail_the_same_bound():
    # The bound above is meaningful: a drift-free map of a slow device
    # clock holds on to the window's oldest minimum, milliseconds off.
    ppm = -100e-6
    m = DeviceClockMapper(window=30.0, min_span=1e9)   # never fits drift
    worst = 0.0
    for device, arrival, true in device_stream(0, ppm, 1234.5):
        m.observe(device, arrival)
        if device - 1234.5 > 5.0:
            worst = max(worst, abs(m.to_global(device) - true))
    assert worst > 1.5e-3


def test_mapper_robust_to_delay_spikes():
    ppm = -50e-6
    stream = device_stream(7, ppm, 20.0)
    rng = random.Random(1)
    m = DeviceClockMapper()
    for device, arrival, true in stream:
        if rng.random() < 0.1:
            arrival += 0.2                        # 200 ms scheduling stalls
        m.observe(device, arrival)
    device, _, true = stream[-1]
    assert m.to_global(device) - true == pytest.approx(0.0, abs=1.5e-3)
    assert m.drift == pytest.approx(-ppm / (1 + ppm), abs=20e-6)


def test_mapper_robust_to_a_reader_stall():
    # The reader stalls 1.8 s (a tracker calibrating): the frame it held
    # arrives 1.8 s late, the device's frames meanwhile are lost.  That one
    # late frame alone in its part of the window must not tilt the map.
    ppm = 80e-6
    m = DeviceClockMapper()
    worst = 0.0
    for device, arrival, true in device_stream(3, ppm, 50.0, dur=20.0):
        if 3.0 <= true - T0 < 4.8:
            continue                              # lost while stalled
        if abs(true - T0 - 2.97) < 0.02:
            arrival = T0 + 4.8                    # held through the stall
        m.observe(device, arrival)
        if device - 50.0 > 5.0:
            worst = max(worst, abs(m.to_global(device) - true))
    assert worst < 2e-3


def test_mapper_is_ready_after_settle_samples_of_each_fit():
    m = DeviceClockMapper(settle=3)
    for k, ready in enumerate([False, False, True, True]):
        m.observe(10.0 + k * 0.1, 11.0 + k * 0.1)
        assert m.ready is ready
    m.observe(0.0, 12.0)                         # the device restarted
    assert not m.ready


def test_mapper_starts_over_when_the_device_clock_goes_back():
    # A sensor restarted: its clock starts again from 0.  The old points
    # must not pull the new stamps 100 s off.
    m = DeviceClockMapper()
    for device, arrival, _ in device_stream(0, 0.0, 100.0, dur=10.0):
        m.observe(device, arrival)
    assert m.resets == 0
    for device, arrival, true in device_stream(1, 0.0, 0.0, dur=1.0,
                                               t0=T0 + 10.5):
        m.observe(device, arrival)
        assert m.to_global(device) - true == pytest.approx(0.0, abs=0.016)
    assert m.resets == 1
    assert m.to_global(device) - true == pytest.approx(0.0, abs=1e-3)
