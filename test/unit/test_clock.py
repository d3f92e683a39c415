"""hri_sync.clock.model: NTP samples, minimum-delay offsets, the drift-fitted
global clock."""

import math
import random
import re

import pytest

from hri_sync.clock.model import (ClockModel, GlobalClock, NtpSample,
                                  OffsetMeasurement, best_offset)


def unread_clock():
    raise AssertionError('the local clock is not read in this test')


def meas(local, offset, delay=0.0002, exchanges=8):
    return OffsetMeasurement(local, offset, delay, exchanges)


# -- NtpSample and best_offset ---------------------------------------------

def test_sample_offset_delay_and_midpoint_are_exact():
    # Sent at local 10, received by the server at 12.25, answered at 12.5,
    # back at local 10.5.
    s = NtpSample(10.0, 12.25, 12.5, 10.5)
    assert s.offset == 2.125          # ((12.25-10) + (12.5-10.5)) / 2
    assert s.delay == 0.25            # 0.5 round trip - 0.25 server hold
    assert s.local_mid == 10.25


def test_symmetric_path_gives_true_offset():
    # Global = local + 1.7; 100 us each way, 30 us hold.
    t1 = 1000.0
    t2 = t1 + 1.7 + 100e-6
    t3 = t2 + 30e-6
    t4 = t3 - 1.7 + 100e-6
    s = NtpSample(t1, t2, t3, t4)
    assert s.offset == pytest.approx(1.7, abs=1e-9)
    assert s.delay == pytest.approx(200e-6, abs=1e-9)


def test_asymmetric_path_error_is_half_the_asymmetry():
    # 400 us out, 100 us back: the offset is off by (400-100)/2 = 150 us,
    # within the uncertainty (half the round trip, 250 us).
    t1 = 50.0
    t2 = t1 + 0.5 + 400e-6
    t3 = t2
    t4 = t3 - 0.5 + 100e-6
    m = best_offset([NtpSample(t1, t2, t3, t4)])
    assert m.offset - 0.5 == pytest.approx(150e-6, abs=1e-9)
    assert m.uncertainty == pytest.approx(250e-6, abs=1e-9)
    assert abs(m.offset - 0.5) <= m.uncertainty


def test_best_offset_keeps_the_minimum_delay_sample():
    samples = [NtpSample(0.0, 1.5, 1.5, 0.5),      # delay 0.5, offset 1.25
               NtpSample(2.0, 3.25, 3.25, 2.25),   # delay 0.25, offset 1.125
               NtpSample(4.0, 6.0, 6.0, 5.0)]      # delay 1.0, offset 1.5
    m = best_offset(iter(samples))                 # any iterable
    assert m == OffsetMeasurement(local=2.125, offset=1.125, delay=0.25,
                                  exchanges=3)
    assert m.uncertainty == 0.125


@pytest.mark.parametrize('bad', [
    NtpSample(10.0, 11.0, 11.5, 10.25),           # hold longer than round trip
    NtpSample(10.0, math.nan, 11.0, 10.5),
    NtpSample(10.0, 11.0, math.inf, 10.5),
])
def test_best_offset_refuses_inconsistent_samples(bad):
    good = NtpSample(0.0, 1.0, 1.0, 0.5)
    with pytest.raises(ValueError, match='inconsistent NTP sample'):
        best_offset([good, bad])


def test_best_offset_of_empty_burst_raises():
    with pytest.raises(ValueError, match='no NTP sample answered'):
        best_offset([])


# -- ClockModel --------------------------------------------------------------

def test_clock_model_maps_both_ways_exactly():
    m = ClockModel(local_ref=100.0, offset=2.0, drift=0.25)
    assert m.offset_at(100.0) == 2.0
    assert m.offset_at(104.0) == 3.0
    assert m.to_global(104.0) == 107.0
    assert m.to_local(107.0) == 104.0
    assert m.to_local(m.to_global(123.456)) == pytest.approx(123.456,
                                                             abs=1e-12)


def test_clock_model_defaults_are_identity_with_infinite_uncertainty():
    m = ClockModel()
    assert m.to_global(5.5) == 5.5 and m.to_local(5.5) == 5.5
    assert m.uncertainty == math.inf


def test_from_state_keeps_the_values():
    m = ClockModel.from_state(1.7e9, -0.9, 2e-4, 0.0003)
    assert (m.local_ref, m.offset, m.drift, m.uncertainty) == (
        1.7e9, -0.9, 2e-4, 0.0003)
    assert m.ready and m.drift_bound == 0.0
    assert m.uncertainty_at(1.7e9 + 100.0) == 0.0003   # no growth known


@pytest.mark.parametrize('fields, what', [
    ((100.0, math.nan, 0.0, 0.001), 'offset=nan is not finite'),
    ((math.inf, 0.0, 0.0, 0.001), 'local_ref=inf is not finite'),
    ((100.0, 0.0, math.nan, 0.001), 'drift=nan is not finite'),
    ((100.0, 0.0, 0.0, math.inf), 'uncertainty=inf is not finite'),
    ((100.0, 0.0, 0.0, -1e-6), 'uncertainty=-1e-06 is negative'),
    ((100.0, 0.0, 0.02, 0.001), 'drift=0.02 exceeds'),
    ((100.0, 0.0, -1.0, 0.001), 'drift=-1.0 exceeds'),
    ((-1.0, 0.0, 0.0, 0.001), 'local_ref=-1.0 s is outside'),
    ((100.0, -200.0, 0.0, 0.001), 'global time at local_ref=-100.0'),
    ((2.0 ** 32, -10.0, 0.0, 0.001), 'local_ref=4294967296.0 s'),
    ((100.0, 2.0 ** 32, 0.0, 0.001), 'global time at local_ref'),
    ((100.0, '1.5', 0.0, 0.001), "offset='1.5' is not a number"),
    ((100.0, 0.0, True, 0.001), 'drift=True is not a number'),
])
def test_from_state_refuses_unusable_values(fields, what):
    with pytest.raises(ValueError, match=re.escape(what)):
        ClockModel.from_state(*fields)


def test_default_model_is_not_ready_and_not_valid():
    with pytest.raises(ValueError, match='uncertainty=inf'):
        ClockModel().validate()


def test_uncertainty_grows_at_the_drift_bound_both_ways():
    m = ClockModel(local_ref=100.0, uncertainty=0.001, drift_bound=1e-4)
    assert m.uncertainty_at(100.0) == 0.001
    assert m.uncertainty_at(110.0) == pytest.approx(0.002, abs=1e-15)
    assert m.uncertainty_at(90.0) == pytest.approx(0.002, abs=1e-15)
    # A snapshot carries the bound of its instant and no growth.
    s = m.snapshot(120.0)
    assert (s.local_ref, s.uncertainty, s.drift_bound) == (
        100.0, pytest.approx(0.003, abs=1e-15), 0.0)
    assert s.uncertainty_at(200.0) == s.uncertainty


# -- GlobalClock -------------------------------------------------------------

def test_global_clock_not_ready_until_first_measurement():
    c = GlobalClock(local_clock=lambda: 10.0)
    assert not c.ready
    c.add(meas(10.0, 1.5, delay=0.001))
    assert c.ready
    assert (c.offset, c.drift, c.local_ref) == (1.5, 0.0, 10.0)
    assert c.uncertainty == 0.0005
    assert c.now() == 11.5


def test_measurements_closer_than_min_span_use_the_best_one_no_drift():
    c = GlobalClock(local_clock=lambda: 0.0, min_span=2.0)
    c.add(meas(100.0, 1.0, delay=0.004))
    c.add(meas(101.0, 1.5, delay=0.002))    # best (smaller delay)
    c.add(meas(101.5, 2.0, delay=0.003))
    assert c.offset == 1.5 and c.drift == 0.0
    assert c.local_ref == 101.5
    assert c.uncertainty == 0.001


def test_two_points_give_exact_drift_and_offset_at_the_last():
    clock_value = [120.0]
    c = GlobalClock(local_clock=lambda: clock_value[0])
    c.add(meas(100.0, 1.0, delay=0.0002))
    c.add(meas(110.0, 1.002, delay=0.0002))
    assert c.drift == pytest.approx(2e-4, rel=1e-9)
    assert c.offset == pytest.approx(1.002, abs=1e-12)
    assert c.local_ref == 110.0
    assert c.uncertainty == pytest.approx(1e-4, abs=1e-12)  # residuals 0
    # Extrapolated 10 s past the last measurement.
    assert c.now() == pytest.approx(120.0 + 1.004, abs=1e-9)
    assert c.to_local(c.now()) == pytest.approx(120.0, abs=1e-9)


def test_drift_is_clamped_and_residuals_enter_the_uncertainty():
    c = GlobalClock(unread_clock, max_drift=1e-3)
    c.add(meas(100.0, 1.0, delay=0.002))
    c.add(meas(110.0, 1.02, delay=0.002))   # 2000 ppm: clamped to 1000
    assert c.drift == 1e-3
    # Line through the centroid (105, 1.01) with the clamped slope.
    assert c.offset == pytest.approx(1.015, abs=1e-12)
    assert c.uncertainty == pytest.approx(0.001 + 0.005, abs=1e-12)


def test_fit_weights_low_delay_measurements():
    # Three clean points on offset = 0.5 + 1e-4 * (local - 0) and one
    # noisy one 5 ms off with a 100x larger delay (10^4 x less weight).
    c = GlobalClock(unread_clock)
    for t in (0.0, 5.0, 10.0):
        c.add(meas(t, 0.5 + 1e-4 * t, delay=1e-4))
    c.add(meas(15.0, 0.5 + 1e-4 * 15 + 0.005, delay=1e-2))
    assert c.drift == pytest.approx(1e-4, abs=2e-6)
    assert c.offset_at(10.0) == pytest.approx(0.501, abs=2e-6)
    # An unweighted fit would be pulled far off (slope error ~1.5e-4).
    unweighted = GlobalClock(unread_clock)
    for t in (0.0, 5.0, 10.0, 15.0):
        unweighted.add(meas(t, 0.5 + 1e-4 * t
                            + (0.005 if t == 15.0 else 0.0), delay=1e-4))
    assert abs(unweighted.drift - 1e-4) > 1e-4


def test_a_queued_burst_does_not_inflate_the_uncertainty():
    # One burst caught in a queue (9 ms round trip, offset 4 ms off), then
    # clean ones: the uncertainty is that of the clean bursts only.
    c = GlobalClock(unread_clock)
    c.add(meas(0.0, 0.5 + 0.004, delay=0.009))
    for t in (5.0, 10.0, 15.0):
        c.add(meas(t, 0.5, delay=1e-4))
    assert c.uncertainty < 1e-4
    # A clean burst far off the line still counts.
    c.add(meas(20.0, 0.5 + 0.002, delay=1e-4))
    assert c.uncertainty > 5e-4


def test_old_measurements_leave_the_window():
    c = GlobalClock(unread_clock, window=20.0)
    c.add(meas(0.0, 9.0))        # a stale, very different offset
    c.add(meas(30.0, 1.0))
    c.add(meas(40.0, 1.001))
    assert [m.local for m in c.measurements] == [30.0, 40.0]
    assert c.drift == pytest.approx(1e-4, rel=1e-6)
    assert c.state() == {'local_ref': 40.0, 'offset': c.offset,
                         'drift': c.drift, 'uncertainty': c.uncertainty,
                         'samples': 2}
    assert ClockModel.from_state(**{k: v for k, v in c.state().items()
                                    if k != 'samples'}).state() == {
        'local_ref': 40.0, 'offset': c.offset, 'drift': c.drift,
        'uncertainty': c.uncertainty}
    assert c.state()['offset'] == pytest.approx(1.001, abs=1e-12)


def test_global_clock_uncertainty_grows_from_the_last_measurement():
    now = [100.0]
    c = GlobalClock(lambda: now[0], drift_bound=20e-6)
    assert c.uncertainty_at(100.0) == math.inf
    c.add(meas(100.0, 1.0, delay=0.002))         # +/- 1 ms at 100
    for elapsed in (0.0, 10.0, 60.0, 600.0):
        assert c.uncertainty_at(100.0 + elapsed) == pytest.approx(
            0.001 + 20e-6 * elapsed, abs=1e-15)
    # The next measurement restarts the growth from its own instant.
    c.add(meas(700.0, 1.0, delay=0.002))
    assert c.local_ref == 700.0
    assert c.uncertainty_at(710.0) == pytest.approx(
        c.uncertainty + 20e-6 * 10.0, abs=1e-15)


def test_global_clock_default_drift_bound_is_ntps_15_ppm():
    c = GlobalClock(unread_clock)
    c.add(meas(0.0, 0.0, delay=0.0))
    assert c.uncertainty_at(1000.0) == pytest.approx(0.015, abs=1e-12)


@pytest.mark.parametrize('bound', [-1e-6, math.nan, math.inf])
def test_global_clock_refuses_a_bad_drift_bound(bound):
    with pytest.raises(ValueError, match='drift bound'):
        GlobalClock(unread_clock, drift_bound=bound)


# -- The key property ------------------------------------------------

EPOCH = 1.7e9          # realistic epoch magnitude (float precision matters)
OFFSET = 1.7           # client clock ahead of the time server, s
PPM = 200e-6           # client clock runs 200 ppm fast


def client_local(true_t):
    """The simulated client's clock reading at true (server) time."""
    return EPOCH + (true_t - EPOCH) * (1.0 + PPM) + OFFSET


def ntp_burst(rng, true_t, exchanges=8):
    """A burst of NTP exchanges with realistic, asymmetric delays."""
    samples = []
    for _ in range(exchanges):
        out = rng.uniform(25e-6, 400e-6)           # one-way delays, so the
        back = rng.uniform(25e-6, 100e-6)          # round trip is 50-500 us
        hold = rng.uniform(5e-6, 30e-6)            # and mostly asymmetric
        t1 = client_local(true_t)
        t2 = true_t + out
        t3 = t2 + hold
        t4 = client_local(t3 + back)
        samples.append(NtpSample(t1, t2, t3, t4))
        true_t = t3 + back + 0.002                 # 2 ms between exchanges
    return best_offset(samples)


def run_window(seed, max_drift=1e-3, resync=5.0, warmup=5.0, window=60.0):
    """Max |global stamp - true time| across a window, in s.

    The CPM measures at true time EPOCH, then every ``resync`` s; the
    window starts ``warmup`` s later and lasts ``window`` s; stamps are
    checked every 10 ms of it.
    """
    rng = random.Random(seed)
    now = [0.0]
    clock = GlobalClock(local_clock=lambda: now[0], max_drift=max_drift)
    next_sync = EPOCH
    t = EPOCH
    worst = 0.0
    start = EPOCH + warmup
    while t < start + window:
        if t >= next_sync:
            clock.add(ntp_burst(rng, t))
            next_sync += resync
        if t >= start:
            now[0] = client_local(t)
            worst = max(worst, abs(clock.now() - t))
            # to_local inverts it: the DPM's wake-up instant for a stamp.
            assert clock.to_local(clock.now()) == pytest.approx(now[0],
                                                                abs=1e-6)
        t += 0.01
    return worst


@pytest.mark.parametrize('seed', range(10))
def test_200ppm_clock_stays_within_1ms_over_60s(seed):
    # The window opens at the second measurement (5 s after the first), the
    # earliest moment a drift can be known.
    worst = run_window(seed, warmup=5.0)
    assert worst < 1e-3
    # In fact much better: the drift fit removes the 200 ppm.
    assert worst < 0.3e-3


def test_before_a_second_measurement_the_error_grows_at_the_clock_rate():
    # One measurement gives no drift: 5 s later a 200 ppm clock is ~1 ms
    # off.  (So the CPM must have measured twice, >= min_span apart, before
    # a window for the bound above to hold.)
    rng = random.Random(3)
    now = [0.0]
    c = GlobalClock(local_clock=lambda: now[0])
    c.add(ntp_burst(rng, EPOCH))
    assert c.drift == 0.0
    now[0] = client_local(EPOCH + 4.99)
    assert c.now() - (EPOCH + 4.99) == pytest.approx(PPM * 4.99, abs=1e-4)


def test_without_drift_estimation_the_same_clock_drifts_out():
    # The bound above can fail: with the drift clamped to 0 the fit is a
    # weighted mean of the window's offsets, which a 200 ppm clock leaves
    # behind by several ms.
    assert run_window(0, max_drift=0.0) > 2e-3


def test_fitted_drift_and_offset_match_the_simulated_clock():
    rng = random.Random(42)
    c = GlobalClock(unread_clock)
    for k in range(13):                       # 60 s of 5 s resyncs
        c.add(ntp_burst(rng, EPOCH + 5.0 * k))
    # global = local + offset(local); d offset / d local = -ppm / (1 + ppm)
    assert c.drift == pytest.approx(-PPM / (1 + PPM), abs=5e-6)
    true_now = EPOCH + 60.0
    assert c.offset_at(client_local(true_now)) == pytest.approx(
        true_now - client_local(true_now), abs=2e-4)
    assert c.uncertainty < 1e-3
    assert c.state()['samples'] == 13
