"""hri_sync_support.skew_figures: a recorded round split into clock error,
delivery delay and start skew, and the run's summary."""
import math
from types import SimpleNamespace as NS

import pytest

from hri_sync_support.harness import FakeClock
from hri_sync_support.skew_figures import analyse_round, summarize

START = 1000.0      # the window's start, global = true time, s
CLOCKS = {'c1': FakeClock(1.5, 1.0002, 900.0),
          'c2': FakeClock(-0.7, 0.9999, 950.0)}


def stamp(t):
    return NS(to_sec=lambda: t)


def header(t):
    """A std_msgs/Header stand-in stamped ``t``."""
    return NS(stamp=stamp(t), frame_id='')


def exact_state(clock, error=0.0):
    """A ClockState whose model maps ``clock``'s local time to the true
    time plus ``error``."""
    return NS(local_ref=clock.local(clock.t0), offset=-clock.offset + error,
              drift=1.0 / clock.rate - 1.0, uncertainty=0.00003)


def round_record(model_errors, delays, frames=200, status='ok',
                 ack_error=0.0):
    """A recorder and a RoundLog record of round 1: each client's clock
    model off by ``model_errors[c]``, its samples (100 Hz from START)
    stamped ``delays[c](k)`` after their true time plus that error."""
    rec = NS(sync={1: (START - 0.4, NS(header=header(START - 0.35)))},
             ack_arrival={1: {'c1': START - 0.3, 'c2': START - 0.28}},
             status={1: []},
             clock_states={c: [(START - 1.0,
                                exact_state(CLOCKS[c], model_errors[c]))]
                           for c in CLOCKS})
    acks = {c: NS(ok=True, reason='', header=header(START - 0.3),
                  offset=CLOCKS[c].offset_at(START - 0.3) + ack_error)
            for c in CLOCKS}
    captured = {c: [(START + k * 0.01 + model_errors[c] + delays[c](k),
                     START + k * 0.01, k) for k in range(frames)]
                for c in CLOCKS}
    results = {c: NS(status=status, frames=frames, coverage=1.0,
                     diagnostics=[], wake_lateness=0.001) for c in CLOCKS}
    capture = NS(round=1, header=header(START - 0.25), str_aft=0.25,
                 dur=2.0, clients=sorted(CLOCKS))
    log_round = {'acks': acks, 'capture': capture, 'results': results,
                 'captured': captured, 'decision': NS(outcome='winner',
                                                      reason='')}
    return rec, log_round


def test_a_round_splits_into_clock_error_and_delivery():
    errors = {'c1': 0.00002, 'c2': -0.00001}
    # c2 is second in line: every sample reaches it 0.3 ms later.
    delays = {'c1': lambda k: 0.0004 + 0.0001 * (k % 3),
              'c2': lambda k: 0.0007 + 0.0001 * (k % 3)}
    rec, lr = round_record(errors, delays, ack_error=0.000003)
    failures = []
    r = analyse_round(1, rec, lr, CLOCKS, failures)
    assert failures == []
    for c in CLOCKS:
        assert r['model_errors'][c] == pytest.approx(errors[c], abs=1e-9)
        # clock error at the start: model error + the least delay
        assert r['errors'][c] == pytest.approx(errors[c] + delays[c](0),
                                               abs=1e-9)
        assert r['delivery'][c] == pytest.approx(delays[c](0), abs=1e-9)
        assert r['delays'][c] == pytest.approx(
            [delays[c](k) for k in range(200)], abs=1e-9)
    assert r['model_skew'] == pytest.approx(0.00003, abs=1e-9)
    assert r['delivery_skew'] == pytest.approx(0.0003, abs=1e-9)
    assert r['skew'] == pytest.approx(0.00027, abs=1e-9)
    assert r['same_first'] is True
    assert r['ack_offset_error'] == pytest.approx([3e-6, 3e-6], abs=1e-9)
    assert r['ack_round'] == pytest.approx(0.12)
    assert r['capture_order'] == pytest.approx(0.1)


def test_own_sensors_have_no_same_first_sample_figure():
    delays = {c: (lambda k: 0.0005) for c in CLOCKS}
    rec, lr = round_record({'c1': 0.0, 'c2': 0.0}, delays)
    r = analyse_round(1, rec, lr, CLOCKS, [], same_sensor=False)
    assert 'same_first' not in r
    assert r['skew'] == pytest.approx(0.0, abs=1e-9)
    args = NS(clients=2, rounds=1, dur=2.0, rate=100.0)
    out = summarize(args, [r], [], CLOCKS, {}, same_sensor=False)
    assert out['rounds_same_first_sample'] is None
    assert out['sample_delay_ms'] == {'p50': 0.5, 'p99': 0.5, 'max': 0.5,
                                      'min': 0.5}


def test_bad_results_and_a_nack_are_failures():
    delays = {c: (lambda k: 0.0005) for c in CLOCKS}
    rec, lr = round_record({'c1': 0.0, 'c2': 0.0}, delays, frames=150,
                           status='partial')
    lr['acks']['c2'] = NS(ok=False, reason='uncertain', header=header(0.0),
                          offset=math.nan)
    del lr['results']['c1']
    failures = []
    analyse_round(1, rec, lr, CLOCKS, failures)
    assert [k for k, _ in failures] == ['nack', 'missing_result',
                                        'result_partial']
    assert 'c2 result partial (150 frames, coverage 1.00)' in failures[2][1]


def test_a_round_that_never_started():
    rec = NS(sync={}, ack_arrival={}, status={}, clock_states={})
    failures = []
    r = analyse_round(3, rec, None, CLOCKS, failures)
    assert r == {'round': 3, 'missing': True}
    assert failures == [('never_started',
                         'round 3 never started (no sync_time seen)')]


def test_summary_of_two_rounds():
    rounds = []
    for e in (0.0001, 0.0003):
        rec, lr = round_record({'c1': e, 'c2': 0.0},
                               {c: (lambda k: 0.0005) for c in CLOCKS})
        rounds.append(analyse_round(1, rec, lr, CLOCKS, []))
    args = NS(clients=2, rounds=2, dur=2.0, rate=100.0)
    out = summarize(args, rounds, [], CLOCKS, {'seed': 5})
    assert out['ok'] is True and out['seed'] == 5
    assert out['start_skew_ms'] == {'p50': 0.1, 'p99': 0.3, 'max': 0.3}
    assert out['clock_skew_ms'] == {'p50': 0.1, 'p99': 0.3, 'max': 0.3}
    assert out['delivery_skew_ms'] == {'p50': 0.0, 'p99': 0.0, 'max': 0.0}
    assert out['sample_delay_p50_ms'] == {'c1': 0.5, 'c2': 0.5}
    assert out['rounds_same_first_sample'] == 2
    assert out['frames_per_window'] == {'expected': 200, 'min': 200,
                                        'p50': 200}
    assert out['clocks']['c1'] == {'offset_s': 1.5, 'drift_ppm': 200.0,
                                   'ack_offset_error_mean_ms': 0.0}


def test_an_unusable_clock_state_is_a_failure_not_a_crash():
    delays = {c: (lambda k: 0.0005) for c in CLOCKS}
    rec, lr = round_record({'c1': 0.0, 'c2': 0.0}, delays)
    rec.clock_states['c2'][-1][1].drift = math.nan
    failures = []
    r = analyse_round(1, rec, lr, CLOCKS, failures)
    assert [k for k, _ in failures] == ['bad_clock_state']
    assert 'c2' in failures[0][1] and 'drift' in failures[0][1]
    assert set(r['model_errors']) == {'c1'} and 'model_skew' not in r
