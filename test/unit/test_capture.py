"""hri_sync.data_process.capture: the sample buffer, window statistics,
the time mappings and the capture window."""

import math
import random
import statistics
from types import SimpleNamespace as NS

import pytest

from hri_sync.data_process.capture import (CaptureWindow, SampleBuffer,
                                           window_stats, window_status)
from hri_sync.clock.model import MAX_DRIFT
from hri_sync.data_process.mapping import (ArrivalStamps, DeviceClockMapper,
                                           TimeMapping)
from hri_sync.data_process.processors import (CountMean, Processor,
                                              ProcessResult)

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


def test_repeated_stamps_are_no_period():
    # A sensor that sends every frame twice: the zero spacings are not a
    # period (they raised ZeroDivisionError) and drop nothing.
    stamps = sorted([FIRST + k * P for k in range(16)] * 2)
    st = window_stats(stamps, 0.0, 1.0)
    assert st == {'coverage': 1.0, 'dropped': 0, 'period': P,
                  'first_frame_offset': FIRST}
    st = window_stats([0.5, 0.5, 0.5], 0.0, 1.0)
    assert math.isnan(st['period']) and st['dropped'] == 0
    assert st['coverage'] == 0.0


def test_a_max_period_shows_a_sensor_slow_all_window():
    # Every third frame of a 16 Hz sensor, evenly (a starved tracker): by
    # its own spacing the window is whole; at most 2 P apart, it is not,
    # and two frames of each three are dropped.
    stamps = [FIRST + k * P for k in range(0, 16, 3)]
    assert window_stats(stamps, 0.0, 1.0)['coverage'] == 1.0
    st = window_stats(stamps, 0.0, 1.0, max_period=P)
    assert st['period'] == P and st['dropped'] == 10
    # Only the edges are covered: the lead and the 0.046875 s tail.
    assert st['coverage'] == P
    # Every other frame, or all of them: within the bound, as before.
    for step in (1, 2):
        some = [FIRST + k * P for k in range(0, 16, step)]
        assert window_stats(some, 0.0, 1.0, max_period=2 * P) == \
            window_stats(some, 0.0, 1.0)


def test_a_max_period_gives_a_lone_sample_its_edges():
    st = window_stats([0.5], 0.0, 1.0, max_period=P)
    assert st['period'] == P and st['dropped'] == 0
    assert st['coverage'] == 0.0             # both edges are 0.5 s gaps
    st = window_stats([FIRST], 0.0, 0.1, max_period=P)
    assert st['coverage'] == 1.0             # lead and tail within 2.5 P


def test_status_rule():
    assert window_status(19, 0.95, 0.9) == 'ok'
    assert window_status(18, 0.9, 0.9) == 'ok'
    assert window_status(10, 0.5, 0.9) == 'partial'
    assert window_status(0, 0.0, 0.9) == 'no_data'
    # Samples in the window, none usable (all malformed): no data, not an
    # ok result of nothing.
    assert window_status(0, 1.0, 0.9) == 'no_data'
    assert window_status(20, 1.0, 0.9, failed=True) == 'error'


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


def test_mapper_reset_and_state():
    m = DeviceClockMapper(settle=2)
    for k in range(3):
        m.observe(10.0 + k, 15.0 + k + 0.001 * k)
    st = m.state()
    assert st['kind'] == 'device' and st['ready'] and st['samples'] == 3
    assert st['offset'] == 5.0 and st['resets'] == 0
    m.reset()
    assert not m.ready and m.resets == 1 and m.samples == 0
    with pytest.raises(ValueError, match='no sample observed'):
        m.to_global(1.0)


def test_mapper_refuses_non_finite_input():
    m = DeviceClockMapper()
    with pytest.raises(ValueError, match='not finite'):
        m.observe(math.nan, 1.0)
    with pytest.raises(ValueError, match='not finite'):
        m.observe(1.0, math.inf)
    assert m.samples == 0


def test_mapper_residual_is_the_envelope_scatter():
    # Jitter-free: the envelope is the line; every bin's minimum on it.
    m = DeviceClockMapper()
    for k in range(300):
        m.observe(k * 0.05, 100.0 + k * 0.05 + 0.002)
    assert m.residual == pytest.approx(0.0, abs=1e-9)
    # 16 Hz over 16 s: 16 bins of 1 s.  Ten of them (the seconds not a
    # multiple of 3) came 1 ms late throughout: the median bin stands 1 ms
    # above the line through the others.
    m = DeviceClockMapper()
    for k in range(257):
        t = k / 16.0
        m.observe(t, 100.0 + t + 0.002 + (0.001 if int(t) % 3 else 0.0))
    assert m.drift == 0.0 and m.offset == pytest.approx(100.002)
    assert m.residual == pytest.approx(0.001)
    # A sample held 2 s by a stalled reader does not raise it.
    m.observe(16.0 + 1 / 16, 100.0 + 16.0 + 1 / 16 + 2.0)
    assert m.residual <= 0.001 + 1e-9


def catching_up(device):
    """The delay of a 30 Hz producer that had fallen 0.8 s behind and
    catches up over 6 s (the virtual Kinect before it dropped late frames,
    on a starved machine), then keeps time."""
    return 0.005 + 0.8 * max(0.0, 1.0 - device / 6.0)


def test_a_producer_catching_up_is_not_read_as_drift():
    m = DeviceClockMapper()
    for k in range(300):
        device = k / 30
        m.observe(device, 1000.0 + device + catching_up(device))
    assert m.drift == -MAX_DRIFT    # the slope is -0.13: delay, not drift
    spacing = m.to_global(9.0) - m.to_global(8.0)
    assert abs(spacing - 1.0) <= MAX_DRIFT + 1e-12


def reference_fit(points, min_span):
    """The mapper's fit as first written in plain Python (30 s Theil-Sen
    through bin minima): the vectorized fit must give the same numbers."""
    ref = points[-1][0]
    span = points[-1][0] - points[0][0]
    if span < min_span:
        return min(d for _, d in points), 0.0, ref
    bins = min(30, max(4, int(span)))
    mins = {}
    for t, d in points:
        k = min(bins - 1, int((t - points[0][0]) / span * bins))
        if k not in mins or d < mins[k][1]:
            mins[k] = (t - ref, d)
    mins = list(mins.values())
    if len(mins) < 2:
        return min(d for _, d in points), 0.0, ref
    slopes = [(b[1] - a[1]) / (b[0] - a[0])
              for i, a in enumerate(mins) for b in mins[i + 1:]
              if b[0] != a[0]]
    drift = statistics.median(slopes) if slopes else 0.0
    drift = min(MAX_DRIFT, max(-MAX_DRIFT, drift))   # a crystal's bound
    base = statistics.median(d - drift * t for t, d in mins)
    offset = base + min(d - (base + drift * (t - ref)) for t, d in points)
    return offset, drift, ref


@pytest.mark.parametrize('seed', range(6))
def test_mapper_fit_is_the_plain_definition(seed):
    rng = random.Random(seed)
    window, min_span = rng.choice([(30.0, 5.0), (3.0, 1.0)])
    m = DeviceClockMapper(window=window, min_span=min_span)
    points = []
    rate = rng.choice([7.0, 30.0, 100.0])
    device, true, ppm = rng.uniform(0, 1e4), T0, rng.uniform(-3e-4, 3e-4)
    for k in range(int(rate * 40)):
        true += 1 / rate
        device += (1 + ppm) / rate
        if rng.random() < 0.003:            # a restart
            device = rng.uniform(0, 100)
        stamp = round(device, 3)            # ties in the bins' minima
        arrival = true + rng.uniform(3e-4, 0.015) + (
            0.2 if rng.random() < 0.05 else 0.0)
        if points and stamp < points[-1][0]:
            points = []
        points.append((stamp, arrival - stamp))
        points = [p for p in points if p[0] >= stamp - window]
        m.observe(stamp, arrival)
        assert (m.offset, m.drift, m.ref) == reference_fit(points, min_span)


# -- the time mapping contract -----------------------------------------------

@pytest.mark.parametrize('mapping', [ArrivalStamps(), DeviceClockMapper()])
def test_both_strategies_keep_the_contract(mapping):
    assert isinstance(mapping, TimeMapping)
    for k in range(6):
        mapping.observe(50.0 + k * 0.1, 1000.0 + k * 0.1)
    assert mapping.ready
    assert mapping.state()['kind'] == mapping.kind
    assert mapping.residual >= 0.0
    mapping.reset()
    assert mapping.state()['samples'] == 0


def test_arrival_stamps_are_the_identity():
    m = ArrivalStamps()
    m.observe(1000.25, 1000.25)
    assert m.ready and m.to_global(1000.25) == 1000.25 and m.residual == 0


# -- CaptureWindow -----------------------------------------------------------

def window(start=100.0, end=101.0, processor=None, **kw):
    return CaptureWindow(7, start, end, processor or CountMean(), **kw)


def sample(v):
    return NS(value=v)


def test_window_keeps_exactly_its_stamps_and_completes_on_a_later_one():
    w = window()
    kept = [w.offer(t, sample(t), t) for t in (99.95, 100.0, 100.5, 100.95)]
    assert kept == [False, True, True, True]
    assert not w.complete
    assert not w.offer(101.0, sample(101.0), 101.0)     # at the end
    assert w.complete and w.completed_by == 'sample'
    status, res, stats, error = w.finish()
    assert (status, error) == ('ok', '')
    assert res.frames_used == 3
    assert res.value == pytest.approx((100.0 + 100.5 + 100.95) / 3)


def test_window_is_due_one_period_and_the_margin_past_its_end():
    w = window(margin=0.03)
    for k in range(20):
        w.offer(100.0 + k * 0.05, sample(1.0), 100.0 + k * 0.05)
    # Newest 100.95: the next sample was due at 101.0, the end.
    assert not w.due(101.029, 0.05)
    assert w.due(101.03, 0.05) and w.completed_by == 'timeout'
    status, res, stats, _ = w.finish()
    assert status == 'ok' and stats['coverage'] == pytest.approx(1.0)


def test_window_waits_for_a_sample_due_after_its_end():
    w = window(margin=0.03)
    w.offer(100.98, sample(1.0), 100.98)
    assert not w.due(101.05, 0.05)              # next due at 101.03
    assert w.due(101.06, 0.05)


def test_silent_sensor_window_is_due_at_its_end_plus_margin():
    w = window(margin=0.03)
    assert not w.due(101.0, math.nan)
    assert w.due(101.03, math.nan)
    status, res, stats, _ = w.finish()
    assert status == 'no_data' and res.frames_used == 0


def test_late_samples_are_counted_not_added():
    w = window(reorder=0.2)
    w.offer(100.1, sample(1.0), 100.1)
    # Stamped before the start, arriving after the end: late.
    assert not w.offer(99.9, sample(5.0), 101.2)
    # Stamped before the start, arriving in time: just not ours.
    assert not w.offer(99.95, sample(5.0), 100.3)
    w.offer(100.6, sample(1.0), 100.6)          # releases 100.1
    assert not w.offer(100.05, sample(9.0), 100.7)   # behind stamp order
    assert w.late == 2
    w.offer(101.0, sample(1.0), 101.0)
    assert not w.offer(100.9, sample(9.0), 101.1)    # after completion
    assert w.late == 3
    _, res, _, _ = w.finish()
    assert res.frames_used == 2 and res.value == 1.0


def test_window_reorders_samples_within_the_reorder_span():
    seen = []

    class Order(Processor):
        def begin(self, start, end):
            pass

        def add(self, frame):
            seen.append(frame.stamp)

        def result(self):
            return ProcessResult(len(seen), len(seen))
    w = window(processor=Order(), reorder=0.2)
    for t in (100.1, 100.3, 100.2, 100.6, 100.55, 100.9):
        assert w.offer(t, None, t)
    w.offer(101.0, None, 101.0)
    w.finish()
    assert seen == sorted(seen) and len(seen) == 6


class Fragile(Processor):
    """Raises on a negative value, fails its result on demand."""

    def __init__(self, fail_result=False):
        self.fail_result = fail_result

    def begin(self, start, end):
        self.n = 0

    def add(self, frame):
        if frame.msg.value < 0:
            raise ValueError('negative')
        self.n += 1

    def result(self):
        if self.fail_result:
            raise RuntimeError('result failed')
        return ProcessResult(float(self.n), self.n)


def test_a_sample_the_processor_raises_on_is_rejected_and_the_window_goes_on():
    w = window(processor=Fragile())
    for k, v in enumerate([1.0, -1.0, 1.0, -2.0, 1.0]):
        assert w.offer(100.0 + 0.1 * k, sample(v), 100.0 + 0.1 * k)
    w.offer(101.0, sample(1.0), 101.0)
    status, res, _, _ = w.finish()
    assert res.frames_used == 3 and res.frames_rejected == 2
    assert res.diagnostics['processor_errors'] == 2
    assert 'negative' in res.diagnostics['processor_error']


def test_a_failing_result_is_an_error_status():
    w = window(processor=Fragile(fail_result=True))
    w.offer(100.5, sample(1.0), 100.5)
    status, res, _, error = w.finish()
    assert status == 'error' and res is None and 'result failed' in error


def test_window_keeps_the_worst_stamp_bound():
    w = window()
    w.offer(100.1, sample(1.0), 100.1, bound=2e-4)
    w.offer(100.2, sample(1.0), 100.2, bound=5e-4)
    w.offer(100.3, sample(1.0), 100.3, bound=1e-4)
    w.offer(99.0, sample(1.0), 99.0, bound=9.0)      # not in the window
    assert w.bound == 5e-4


def test_empty_window_is_refused():
    with pytest.raises(ValueError, match='empty or not finite'):
        window(100.0, 100.0)
    with pytest.raises(ValueError, match='empty or not finite'):
        window(math.nan, 101.0)
