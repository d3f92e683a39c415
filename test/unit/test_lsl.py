"""LSL in: the time-correction fit, the stamper, the processor and the
DPM's host stamps (hri_sync.sensors.lsl; docs/lsl.md)."""
import math
import random
from types import SimpleNamespace as NS

import pytest

from hri_sync.sensors.lsl import (CLOCK_RESET, DATA, LOST, TICK, ClockBreak,
                                  CorrectionFit, LslChannels, LslStamper,
                                  StreamGaps, inlet_health)
from hri_sync.clock.model import ClockModel
from hri_sync.data_process.dpm import DataProcess
from hri_sync.data_process.processors import Frame
from hri_sync.wire.validate import Rejected


def drifting(t, offset=3.0, drift=2e-4):
    """A remote clock's correction at local time t."""
    return offset + drift * t


def test_fit_follows_drift_between_estimates():
    fit = CorrectionFit()
    for t in range(0, 20, 2):           # an estimate every 2 s
        fit.add(float(t), drifting(t), 1e-4)
    assert fit.slope == pytest.approx(2e-4, rel=1e-6)
    # 1.5 s after the last estimate: the last value is 0.3 ms off, the fit
    # is not.
    assert abs(fit.correction(19.5) - drifting(19.5)) < 1e-9
    assert abs(drifting(18) - drifting(19.5)) > 2.9e-4
    # Half a round trip, plus the slope's error over 1.5 s.
    assert fit.bound(19.5) == pytest.approx(5e-5 + 1e-4 / 18 * 1.5)


def test_fit_ignores_repeats_and_one_outlier():
    fit = CorrectionFit()
    for t in range(10):
        fit.add(float(t), drifting(t), 1e-4)
        fit.add(float(t), drifting(t), 1e-4)      # repeated: ignored
    fit.add(10.0, drifting(10) + 0.01, 1e-4)            # a bad estimate
    assert len(fit.points) == 11
    assert abs(fit.correction(11) - drifting(11)) < 1e-6


def test_fit_with_one_estimate_grows_its_bound():
    fit = CorrectionFit(drift_bound=5e-4)
    assert fit.bound(0) == math.inf and not fit.ready
    fit.add(10.0, 1.0, 2e-4)
    assert fit.correction(12.0) == 1.0
    assert fit.bound(12.0) == pytest.approx(1e-4 + 1e-3)
    with pytest.raises(ValueError):
        fit.add(11.0, math.nan)


def stamper():
    fit = CorrectionFit()
    fit.add(0.0, 5.0, 1e-4)
    fit.add(2.0, 5.0 + 1e-9, 1e-4)
    return LslStamper(fit, settle=3)


def test_stamper_maps_to_the_wall_clock():
    s = stamper()
    host, bound = s.stamp(95.0, 100.01, 1000.0)
    assert host == pytest.approx(1100.0, abs=1e-6)
    assert bound == pytest.approx(5e-5 + 1e-4 / 2 * 98.01)


def test_stamper_catches_a_clock_reset_and_stays_broken():
    s = stamper()
    for k in range(10):
        s.stamp(95.0 + 0.01 * k, 100.0 + 0.01 * k + 0.002, 0.0)
    with pytest.raises(ClockBreak, match='went back'):
        s.stamp(93.1, 100.102, 0.0)
    # The stream goes on from its new base: consistent among themselves,
    # but 2 s before their delivery: still refused.
    for k in range(10):
        with pytest.raises(ClockBreak):
            s.stamp(93.11 + 0.01 * k, 100.112 + 0.01 * k, 0.0)
    assert s.broken


def test_stamper_recovers_when_samples_map_again():
    s = stamper()
    s.stamp(95.0, 100.001, 0.0)
    with pytest.raises(ClockBreak, match='future'):
        s.stamp(96.0, 100.011, 0.0)
    # LSL's next estimate or the stream corrects it: after settle samples.
    for k in range(2):
        with pytest.raises(ClockBreak):
            s.stamp(95.02 + 0.01 * k, 100.021 + 0.01 * k, 0.0)
    host, _ = s.stamp(95.04, 100.041, 0.0)
    assert host == pytest.approx(100.04, abs=1e-6) and not s.broken


def sample(kind=DATA, stamp=1.0, channels=(), markers=(), reason='',
           error=1e-4):
    return NS(kind=kind, header=NS(stamp=stamp), channels=list(channels),
              markers=list(markers), reason=reason, stamp_error=error,
              lsl_stamp=stamp, nominal_rate=0.0)


def test_processor_counts_means_markers_and_events():
    p = LslChannels()
    p.begin(10.0, 12.0)
    for k in range(4):
        p.add(Frame(10.0 + k * 0.1, sample(channels=(k, 2.0))))
    p.add(Frame(10.5, sample(TICK)))
    p.add(Frame(11.0, sample(markers=('go',))))
    p.add(Frame(11.2, sample(LOST, reason='the outlet is gone')))
    r = p.result()
    assert r.value == 5 and r.frames_used == 5
    assert r.diagnostics['channel_means'] == '1.5 2'
    assert r.diagnostics['markers'] == '+1.0000 go'
    assert r.diagnostics['lsl_stream'].startswith('lost at +1.200 s: the '
                                                  'outlet is gone')
    assert r.diagnostics['rate'] == pytest.approx(2.5)


@pytest.mark.parametrize('msg', [sample(kind=9), sample(channels=(math.nan,)),
                                 sample(error=math.nan)])
def test_processor_rejects_malformed(msg):
    with pytest.raises(Rejected):
        LslChannels().check(msg)


def test_dpm_maps_host_stamps_by_the_clock_model_alone():
    dp = DataProcess(LslChannels)
    assert dp.stamp_source == 'host'
    dp.set_clock(ClockModel(1000.0, 3.0, 0.0, 1e-4))
    dp.open(1, 1003.5, 1004.0)
    steps = [dp.on_sample(sample(stamp=1000.5 + 0.01 * k, channels=(k,),
                                 error=2e-4), 1000.52 + 0.01 * k)
             for k in range(60)]
    results = [r for s in steps for r in s.results]
    assert len(results) == 1
    r = results[0]
    assert r.frames == 50 and r.status == 'ok'
    assert 3e-4 <= r.timing_uncertainty < 3.5e-4
    # A stamp after its own arrival, or none, is refused and counted.
    dp.on_sample(sample(stamp=1002.0, channels=(1,)), 1001.0)
    dp.on_sample(sample(stamp=math.nan, channels=(1,)), 1001.0)
    assert dp.counts['bad_device_stamp'] == 1
    assert dp.counts['no_device_stamp'] == 1


def test_clock_reset_kind_is_an_event():
    p = LslChannels()
    p.begin(0.0, 1.0)
    p.add(Frame(0.5, sample(CLOCK_RESET, reason='the stamp went back 2 s')))
    r = p.result()
    assert r.frames_used == 0
    assert r.diagnostics['lsl_stream'].startswith('clock_reset at +0.500')


# -- LSL out (hri_sync.tools.lsl_markers) -----------------------------------

def test_marker_text_round_trips_and_refuses_nan():
    from hri_sync.tools.lsl_markers import marker_text, parse_marker
    d = parse_marker(marker_text('result', 3, 1000.1234567, 1e-4,
                                 client='a', value=None))
    assert d == {'event': 'result', 'round': 3, 'global_time': 1000.123457,
                 'bound': 0.0001, 'client': 'a', 'value': None}
    with pytest.raises(ValueError):
        marker_text('result', 3, 1000.0, 1e-4, value=math.nan)
    with pytest.raises(ValueError):
        marker_text('party', 3, 1000.0, 1e-4)
    with pytest.raises(ValueError):
        parse_marker('{"event": "other"}')


def test_capture_events_are_the_window():
    from hri_sync.tools.lsl_markers import capture_events
    (e1, t1, f1), (e2, t2, _) = capture_events(2, 100.0, 0.5, 4.0, ['a'])
    assert (e1, t1, e2, t2) == ('window_start', 100.5, 'window_end', 104.5)
    assert f1 == {'clients': ['a'], 'dur': 4.0}


def test_marker_clock_maps_global_to_lsl_with_bound():
    from hri_sync.tools.lsl_markers import MarkerClock
    c = MarkerClock()
    with pytest.raises(ValueError):
        c.to_lsl(1000.0, 50.0)
    c.model = ClockModel(900.0, 3.0, 0.0, 2e-4)
    stamp, bound = c.to_lsl(1003.0, 50.0)
    assert stamp == pytest.approx(950.0) and bound == pytest.approx(2e-4)


def test_unread_markers_are_counted_and_reported_once_a_round():
    from hri_sync.tools.lsl_markers import Unread
    u = Unread()
    assert 'round 1' in u.pushed(1, consumers=False)
    assert u.pushed(1, consumers=False) == ''
    assert u.pushed(2, consumers=True) == ''
    assert u.total == 2 and u.summary() == '1: 2'


def test_kinds_match_the_message():
    import os
    import re
    from hri_sync.sensors import lsl
    path = os.path.join(os.path.dirname(__file__), '..', '..', 'msg',
                        'LslSample.msg')
    with open(path) as f:
        found = dict(re.findall(r'^uint8 ([A-Z_]+)=(\d+)', f.read(), re.M))
    assert {k: int(v) for k, v in found.items()} == {
        'DATA': lsl.DATA, 'TICK': lsl.TICK, 'LOST': lsl.LOST,
        'CLOCK_RESET': lsl.CLOCK_RESET, 'RECOVERED': lsl.RECOVERED}


def test_fit_leaves_out_slow_exchanges():
    fit = CorrectionFit()
    for t in range(0, 20, 2):
        # A loaded host: every third exchange slow and 0.4 ms off.
        slow = t % 6 == 4
        fit.add(float(t), drifting(t) + (3e-4 if slow else 0.0),
                1e-3 if slow else 7e-5)
    assert abs(fit.correction(21.0) - drifting(21.0)) < 1e-9
    assert fit.bound(21.0) == pytest.approx(3.5e-5 + 7e-5 / 18 * 3)


def test_activity_is_the_rms_deviation_from_the_window_mean():
    p = LslChannels(measure='activity')
    p.begin(0.0, 1.0)
    for k, x in enumerate((1.0, 3.0, 1.0, 3.0)):
        p.add(Frame(0.1 * k, sample(channels=(x, 9.81))))
    r = p.result()
    # Gravity (a constant channel) drops out; 1, 3, 1, 3: 1 from its mean.
    assert r.value == pytest.approx(1.0) and r.frames_used == 4
    with pytest.raises(ValueError):
        LslChannels(measure='loudness')
    q = LslChannels(measure='activity')
    q.begin(0.0, 1.0)
    q.add(Frame(0.5, sample(markers=('go',))))
    assert math.isnan(q.result().value)


# -- a stream delivered in bursts (StreamGaps, LslChannels' sample clock) ----

RATE = 100.0


def bursty(seed, seconds=60.0, lost=(), push_stamped=True, drift=5e-5):
    """A 100 Hz stream's deliveries, [(pull time, [LSL stamps])]: sample k
    taken at k / RATE (a device ``drift`` slow), the ranges in ``lost``
    never pushed; the outlet pushes what it has every 0.02-0.4 s (seeded),
    stamped when pushed (``push_stamped``, LSL's default) or when taken;
    the inlet pulls each push 1-3 ms later."""
    rng = random.Random(seed)
    gone = {k for a, b in lost for k in range(a, b)}
    taken = [k / RATE * (1 + drift) for k in range(int(seconds * RATE))
             if k not in gone]
    out, i, t = [], 0, 0.0
    while i < len(taken):
        t += rng.uniform(0.02, 0.4)
        push = [s for s in taken[i:] if s <= t]
        i += len(push)
        if push:
            stamps = ([t + 1e-6 * j for j in range(len(push))]
                      if push_stamped else push)
            out.append((t + rng.uniform(1e-3, 3e-3), stamps))
    return out


@pytest.mark.parametrize('seed', [1, 2, 3])
@pytest.mark.parametrize('push_stamped', [True, False])
def test_bursts_lose_nothing_and_real_gaps_are_counted(seed, push_stamped):
    lost = ((1500, 1505), (3000, 3012), (4500, 4540))
    g = StreamGaps(RATE)
    for pulled, stamps in bursty(seed, lost=lost, push_stamped=push_stamped):
        g.deliver(stamps, pulled)
    assert g.samples == 6000 - 57 and g.gaps == 3
    # Stamped when pushed, each stamp is up to a period late: the count
    # of a gap may be one off (7 of 100 seeds tried here).
    assert abs(g.lost - 57) <= (1 if push_stamped else 0)
    assert g.bursts > 100 and g.largest_burst >= 30


def test_a_stream_in_bursts_without_a_loss_has_no_gap():
    g = StreamGaps(RATE)
    for pulled, stamps in bursty(4, seconds=300.0):
        g.deliver(stamps, pulled)
    assert (g.samples, g.gaps, g.lost) == (30000, 0, 0)


def test_an_irregular_stream_has_no_bursts_nor_gaps():
    g = StreamGaps(0.0)
    g.deliver([1.0, 1.0001], 1.0)
    g.deliver([5.0, 5.1], 5.2)
    assert (g.samples, g.bursts, g.gaps) == (4, 0, 0)


def window_of(deliveries, start, end, nominal=RATE):
    """The DPM's result of [start, end) (host stamps = LSL stamps + 1000
    s, a clock model with offset 0) over the deliveries."""
    dp = DataProcess(LslChannels)
    dp.set_clock(ClockModel(0.0, 0.0, 0.0, 1e-4))
    dp.open(1, start + 1000.0, end + 1000.0)
    results = []
    for pulled, stamps in deliveries:
        for s in stamps:
            msg = sample(stamp=s + 1000.0, channels=(1.0,))
            msg.nominal_rate = nominal
            results += dp.on_sample(msg, pulled + 1000.0).results
    return results[0]


@pytest.mark.parametrize('seed', [5, 6])
def test_a_window_of_a_stream_in_bursts_is_whole(seed):
    """Stamped when pushed, a burst's stamps bunch: judged by their
    spacing (the DPM's own rule), thousands of samples 'dropped' and the
    window partial; on the stream's nominal rate, whole."""
    r = window_of(bursty(seed, seconds=20.0), 5.0, 15.0)
    assert r.status == 'ok' and r.frames_dropped == 0, r
    assert r.coverage >= 0.95
    assert r.diagnostics['expected_samples'] == 1000


def test_a_window_with_a_real_gap_counts_it():
    lost = ((800, 830),)
    r = window_of(bursty(7, seconds=20.0, lost=lost, push_stamped=False),
                  5.0, 15.0)
    assert r.frames_dropped == 30 and r.frames == 970
    assert r.coverage == pytest.approx(0.97)


def test_inlet_health_says_gaps_bursts_and_the_fit():
    g = StreamGaps(RATE)
    for pulled, stamps in bursty(8, lost=((1000, 1010),)):
        g.deliver(stamps, pulled)
    fit = CorrectionFit()
    for k in range(6):
        fit.add(2.0 * k, drifting(2.0 * k), 1e-4)
    h = inlet_health('eeg (100 Hz)', g, fit, 12.0,
                     {'dropped_clock': 0, 'lost': 0})
    assert h.level == 1 and h.message.startswith('1 real gaps (10 samples')
    assert h.value('bursts') == str(g.bursts) and g.bursts > 0
    assert h.value('fit_estimates') == '6'
    assert float(h.value('fit_drift_ppm')) == pytest.approx(200.0)
    assert 0 < float(h.value('fit_bound_ms')) < 1.0
    quiet = inlet_health('', StreamGaps(RATE), CorrectionFit(), 0.0, {})
    assert quiet.message == 'no LSL stream resolved yet'
    clean = StreamGaps(RATE)
    clean.deliver([0.0, 0.01], 0.011)
    assert inlet_health('eeg', clean, fit, 12.0, {}).level == 0
