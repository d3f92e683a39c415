"""hri_sync.wire.health: the /diagnostics statuses from plain values, on
fake clocks."""

import math
from types import SimpleNamespace

import pytest

from hri_sync.clock.model import ClockModel, OffsetMeasurement
from hri_sync.clock.sync import ClockStatus, ClockSync
from hri_sync.control.session import ControlSession, RoundEnd, StatusUpdate
from hri_sync.client_process.health import client_tally
from hri_sync.clock.health import clock_health, clock_state_health
from hri_sync.control.health import ServerTally
from hri_sync.data_process.health import result_tally
from hri_sync.decision.health import DecisionTally
from hri_sync.wire.health import (ERROR, OK, WARN, Health, RateMeter,
                                  RejectionWatch, RoundTally, text)
from hri_sync.clock.ntp import NtpError
from hri_sync.client_process.schedule import ClientSchedule
from hri_sync.wire.protocol import StrAftPolicy

DOWN = 'time server 127.0.0.1:11742 did not answer within 0.50 s'
CLOCK_KEYS = ['synced', 'reason', 'uncertainty_ms', 'max_uncertainty_ms',
              'since_last_sync_s', 'drift_ppm', 'offset_ms', 'samples',
              'last_error']


def status(uncertainty=0.001, local_ref=1000.0, error='', drift=2e-6,
           drift_bound=15e-6, samples=4, offset=1.7):
    return ClockStatus(ClockModel(local_ref, offset, drift, uncertainty,
                                  drift_bound), error, samples)


def values(h):
    return dict(h.values)


# -- text ------------------------------------------------------------------

def test_text_formats_every_kind_of_value():
    assert text(True) == 'true' and text(False) == 'false'
    assert text(None) == 'none'
    assert text(1.23456) == '1.235'
    assert text(1.23456, '%.1f') == '1.2'
    assert text(math.nan) == 'nan' and text(math.inf) == 'inf'
    assert text(7) == '7' and text('x') == 'x'


# -- clock_health ----------------------------------------------------------

def test_a_fresh_model_is_ok_and_says_its_figures():
    h = clock_health(status(), 1002.0, max_uncertainty=0.005,
                     stale_after=20.0)
    assert h.level == OK
    assert h.message == ('synced: uncertainty 1.030 ms (limit 5.000 ms), '
                         'drift +2.00 ppm')
    assert [k for k, _ in h.values] == CLOCK_KEYS
    v = values(h)
    assert v['synced'] == 'true' and v['reason'] == ''
    assert v['uncertainty_ms'] == '1.030'
    assert v['max_uncertainty_ms'] == '5.000'
    assert v['since_last_sync_s'] == '2.0'
    assert v['drift_ppm'] == '+2.000'
    assert v['offset_ms'] == '1700.004'
    assert v['samples'] == '4' and v['last_error'] == ''


def test_no_model_is_an_error_with_the_measurement_s_reason():
    h = clock_health(ClockStatus(ClockModel(), DOWN, 0), 1000.0, 0.005)
    assert h.level == ERROR
    assert h.message == 'not synced: ' + DOWN
    v = values(h)
    assert v['synced'] == 'false' and v['reason'] == h.message
    assert v['uncertainty_ms'] == 'inf'
    assert v['since_last_sync_s'] == 'never'
    assert v['drift_ppm'] == 'nan' and v['last_error'] == DOWN


def test_no_model_before_the_first_measurement():
    h = clock_health(ClockStatus(ClockModel(), '', 0), 1000.0)
    assert (h.level, h.message) == (ERROR, 'not synced: not measured yet')


def test_over_the_limit_is_an_error():
    h = clock_health(status(uncertainty=0.006), 1000.0, 0.005)
    assert h.level == ERROR
    assert h.message == 'uncertainty 6.000 ms exceeds its limit 5.000 ms'


def test_holdover_is_a_warning_until_the_bound_passes_the_limit():
    # 1 ms at the last sync, growing at 15 ppm: 5 ms after 266.7 s.
    h = clock_health(status(error=DOWN), 1100.0, 0.005)
    assert h.level == WARN
    assert h.message == ('holdover: no good sync for 100.0 s (%s); '
                         'uncertainty 2.500 ms of 5.000 ms' % DOWN)
    h = clock_health(status(error=DOWN), 1300.0, 0.005)
    assert h.level == ERROR
    assert h.message == ('uncertainty 5.500 ms exceeds its limit 5.000 ms; '
                         'no good sync for 300.0 s: ' + DOWN)


def test_an_overdue_sync_is_a_warning():
    h = clock_health(status(drift_bound=0.0), 1030.0, 0.005,
                     stale_after=20.0)
    assert h.level == WARN
    assert h.message == 'last good sync 30.0 s ago, more than 20.0 s'


def test_near_the_limit_is_a_warning():
    h = clock_health(status(uncertainty=0.0045, drift_bound=0.0), 1000.0,
                     0.005)
    assert h.level == WARN
    assert h.message == 'uncertainty 4.500 ms near its limit 5.000 ms'
    assert clock_health(status(uncertainty=0.0045, drift_bound=0.0), 1000.0,
                        0.005, near=0.95).level == OK


def test_without_a_limit_only_the_model_and_its_freshness_count():
    h = clock_health(status(uncertainty=10.0), 1000.0)
    assert h.level == OK
    assert h.message == 'synced: uncertainty 10000.000 ms, drift +2.00 ppm'
    assert values(h)['max_uncertainty_ms'] == 'none'


class FakeHost:
    """A local clock that moves when told to, and a time server that can
    be switched off."""

    def __init__(self):
        self.t = 1000.0
        self.up = True

    def measure(self):
        if not self.up:
            raise NtpError(DOWN)
        return OffsetMeasurement(self.t, 1.7, 0.002, 8)


def test_the_status_is_an_error_exactly_when_the_cpm_nacks():
    """Through the time server's death: ERROR on /diagnostics iff the
    CPM's ACK rule NACKs, with the same cause."""
    host = FakeHost()
    sync = ClockSync(host.measure, lambda: host.t)
    schedule = ClientSchedule('left', max_uncertainty=0.005)
    seen = []
    for step in range(60):
        host.t = 1000.0 + 10.0 * step
        host.up = step < 5
        st = sync.sync()
        reply = schedule.on_sync(step, host.t, host.t, st)
        h = clock_health(st, host.t, 0.005)
        assert (h.level == ERROR) == (not reply.ok), step
        if not reply.ok:
            assert DOWN in h.message and DOWN in reply.reason
        seen.append(h.level)
    assert seen[:5] == [OK] * 5
    assert WARN in seen and seen[-1] == ERROR


def test_a_clock_state_read_by_another_node():
    model = ClockModel(1000.0, 1.7, 2e-6, 0.0005)
    h = clock_state_health('left/cpm', model, '', 6, 1004.0, 4.0, 20.0)
    assert (h.level, h.message) == (OK, 'synced: uncertainty 0.500 ms, '
                                    'drift +2.00 ppm')
    assert h.value('since_last_sync_s') == '4.0'
    assert h.value('clock_state_age_s') == '4.0'
    h = clock_state_health('left/cpm', model, '', 6, 1030.0, 30.0, 20.0)
    assert (h.level, h.message) == (
        WARN, 'no clock_state from left/cpm for 30.0 s, more than 20.0 s')
    hold = 'holdover: no good sync for 12.0 s (%s); uncertainty 0.680 ms' \
        % DOWN
    h = clock_state_health('left/cpm', model, hold, 6, 1012.0, 0.1)
    assert (h.level, h.message, h.value('reason')) == (WARN, hold, hold)
    h = clock_state_health('left/cpm', None, DOWN, 0, 1000.0, 0.2)
    assert (h.level, h.message) == (ERROR, 'not synced: ' + DOWN)
    assert h.value('since_last_sync_s') == 'never'
    h = clock_state_health('/server/clock_state', None, '', 0, 1000.0, None)
    assert (h.level, h.message) == (
        ERROR, 'no clock_state from /server/clock_state yet')
    assert h.value('clock_state_age_s') == 'never'


# -- RoundTally ------------------------------------------------------------

def test_a_tally_before_any_round():
    h = client_tally().health()
    assert (h.level, h.message) == (OK, 'no round yet')
    assert h.values == (
        ('last_round', 'none'), ('last_outcome', ''), ('last_reason', ''),
        ('acked_count', '0'), ('nacked_count', '0'),
        ('scheduled_count', '0'), ('late_count', '0'))


def test_the_last_event_sets_the_level_and_every_event_is_counted():
    t = client_tally()
    t.record(1, 'acked')
    t.record(1, 'scheduled', 'order 480 ms ahead of the window')
    h = t.health()
    assert (h.level, h.message) == (
        OK, 'round 1: scheduled: order 480 ms ahead of the window')
    t.record(2, 'acked')
    t.record(2, 'late', 'capture_data arrived 12.0 ms after the start')
    h = t.health()
    assert h.level == WARN
    assert h.message == ('round 2: late: capture_data arrived 12.0 ms '
                         'after the start')
    assert h.value('last_round') == '2'
    assert h.value('acked_count') == '2'
    assert h.value('late_count') == '1'
    t.record(3, 'nacked', 'no clock model yet')
    assert t.health().level == WARN
    t.record(4, 'acked')
    assert t.health().level == OK
    assert t.health().value('nacked_count') == '1'


def test_a_tally_refuses_outcomes_it_does_not_count():
    t = client_tally()
    with pytest.raises(ValueError, match="'decided' is not one of"):
        t.record(1, 'decided')
    with pytest.raises(ValueError, match='client outcome'):
        t.count('missing', ['left'])
    with pytest.raises(ValueError, match='not counted: x'):
        RoundTally(('a',), {'x': WARN})


def test_the_version_changes_with_every_event():
    t = ServerTally()
    versions = [t.version]
    t.record(1, 'syncing')
    versions.append(t.version)
    t.count('missing', ['c'])
    versions.append(t.version)
    t.health()
    assert t.version == versions[-1]
    assert len(set(versions)) == 3


def test_a_dpm_s_results():
    r = result_tally()
    r.record(1, 'no_data', 'no sample in the window')
    assert r.health().level == WARN
    r.record(2, 'error', 'processor failed')
    assert r.health().level == ERROR
    r.record(3, 'ok')
    h = r.health()
    assert h.level == OK
    assert [h.value('%s_count' % s) for s in
            ('ok', 'partial', 'no_data', 'late', 'error')] == \
        ['1', '0', '1', '0', '1']


def test_the_dm_counts_results_and_missing_ones_per_participant():
    d = DecisionTally(['left', 'right'])
    d.on_result(1, 'left', 'ok')
    d.on_result(1, 'right', 'late')
    d.on_decision(1, 'winner', 'left scored highest')
    d.on_result(2, 'left', 'no_data')
    d.on_decision(2, 'no_winner', 'no usable result')
    h = d.health()
    assert (h.level, h.message) == (OK, 'round 2: no_winner: no usable '
                                    'result')
    assert [h.value('left %s_count' % s) for s in
            ('ok', 'no_data', 'missing')] == ['1', '1', '0']
    assert [h.value('right %s_count' % s) for s in
            ('late', 'missing')] == ['1', '1']
    d.on_decision(3, 'aborted', 'round 3 aborted: no ACK from right',
                  count_missing=False)
    h = d.health()
    assert h.level == WARN and h.value('right missing_count') == '1'
    d.on_result(4, 'left', 'weird')
    assert d.health().value('left error_count') == '1'


# -- ServerTally -----------------------------------------------------------

def test_every_client_s_counts_are_shown_from_zero():
    h = ServerTally(['left', 'right']).health()
    assert [k for k, _ in h.values][-4:] == [
        'left refused_count', 'left missing_count', 'right refused_count',
        'right missing_count']
    assert {v for _, v in h.values[-4:]} == {'0'}
    t = DecisionTally(['left', 'right'])
    t.count('missing', ['other'])
    keys = [k for k, _ in t.health().values]
    assert keys.index('right missing_count') < keys.index('other ok_count')


def test_a_decided_round_and_a_quorum_round():
    t = ServerTally(['left', 'right'])
    t.on_status(1, 'syncing', '', [], ['left', 'right'])
    assert t.health().message == 'round 1: syncing'
    t.on_status(1, 'capturing', 'quorum without right', ['right'], [])
    t.on_end(1, 'decided', 'round 1 decided')
    h = t.health()
    assert (h.level, h.message) == (OK, 'round 1: decided: round 1 decided')
    assert h.value('right refused_count') == '1'
    assert h.value('right missing_count') == '0'
    assert h.value('left refused_count') == '0'
    assert h.value('syncing_count') == '1'
    assert h.value('decided_count') == '1'


def test_an_abort_is_a_warning_counted_once():
    t = ServerTally()
    t.on_status(2, 'syncing', '', [], ['c'])
    t.on_status(2, 'aborted', 'round 2 aborted: no ACK from c', [], ['c'])
    t.on_end(2, 'aborted', 'round 2 aborted: no ACK from c')
    h = t.health()
    assert (h.level, h.message) == (
        WARN, 'round 2: aborted: round 2 aborted: no ACK from c')
    assert h.value('aborted_count') == '1'
    assert h.value('c missing_count') == '1'
    t.on_end(3, 'aborted', 'round 3 aborted: no server clock')
    assert t.health().value('aborted_count') == '2'


def test_a_missing_decision_and_a_shutdown():
    t = ServerTally()
    t.on_status(4, 'capturing', '', [], [])
    t.on_end(4, 'no_decision', 'round 4 captured, no decision')
    h = t.health()
    assert (h.level, h.message) == (
        ERROR, 'round 4: no_decision: round 4 captured, no decision')
    t.on_status(5, 'syncing', '', [], [])
    t.on_end(5, 'shutdown', 'round 5: shut down')
    assert t.health().level == WARN


def test_the_cm_s_session_events_feed_the_tally():
    """A quorum round and an abort through ControlSession, its outputs
    fed as the control module feeds them."""
    session = ControlSession(['a', 'b', 'c'], 2.0, StrAftPolicy(fixed=0.5),
                             min_clients=2)
    t = ServerTally(['a', 'b', 'c'])

    def feed(outputs):
        for out in outputs:
            if isinstance(out, StatusUpdate):
                t.on_status(out.round, out.state, out.reason, out.refused,
                            out.missing)
            elif isinstance(out, RoundEnd):
                t.on_end(out.round, out.outcome, out.message)
    feed(session.start(100.0))
    for client, ok in (('a', True), ('b', True), ('c', False)):
        feed(session.on_ack(SimpleNamespace(
            round=1, client_id=client, ok=ok, reason='' if ok else 'far',
            offset=0.0, uncertainty=0.001, sync_received=100.01)))
    feed(session.poll(100.1))
    assert t.health().value('last_outcome') == 'capturing'
    feed(session.on_decision(1))
    feed(session.poll(103.0))
    h = t.health()
    assert (h.level, h.value('last_outcome')) == (OK, 'decided')
    assert h.value('c refused_count') == '1'
    feed(session.start(110.0))
    feed(session.poll(120.0))
    h = t.health()
    assert (h.level, h.value('last_round')) == (WARN, '2')
    assert h.value('aborted_count') == '1'
    assert [h.value('%s missing_count' % c) for c in 'abc'] == ['1'] * 3


# -- RateMeter -------------------------------------------------------------

def test_a_sensor_that_never_sent_is_an_error():
    m = RateMeter('/left/skeleton')
    h = m.health(10.0)
    assert (h.level, h.message) == (ERROR, 'no sample on /left/skeleton yet')
    assert h.value('since_last_sample_s') == 'never'
    assert h.value('rate_hz') == 'nan'


def test_the_rate_over_the_window_and_a_silence():
    m = RateMeter('/left/skeleton', window=5.0, silent_after=1.0)
    for i in range(201):                       # 20 Hz for 10 s
        m.observe(100.0 + i * 0.05)
    h = m.health(110.01)
    assert h.level == OK
    assert h.message == '/left/skeleton at 20.0 Hz'
    assert h.value('rate_hz') == '20.00'
    assert h.value('samples_total') == '201'
    h = m.health(112.0)
    assert (h.level, h.message) == (
        ERROR, 'no sample on /left/skeleton for 2.0 s')
    assert h.value('since_last_sample_s') == '2.00'


def test_a_slow_sensor_is_a_warning():
    m = RateMeter('/s', min_rate=15.0)
    for i in range(11):                         # 10 Hz
        m.observe(i * 0.1)
    h = m.health(1.05)
    assert (h.level, h.message) == (WARN, '/s at 10.0 Hz, below 15.0 Hz')


def test_rate_meter_params_are_checked():
    with pytest.raises(ValueError, match='window'):
        RateMeter('/s', window=0.0)
    with pytest.raises(ValueError, match='silent_after'):
        RateMeter('/s', silent_after=math.nan)


# -- RejectionWatch --------------------------------------------------------

def test_rejections_warn_while_they_grow():
    w = RejectionWatch(recent=60.0)
    h = w.health({}, 0.0)
    assert (h.level, h.message) == (OK, 'no message rejected')
    assert h.values == (('rejected_total', '0'),)
    counts = {'/capture_data unacked_round': 2, '/capture_data malformed': 1,
              '/sync_time accepted': 40}
    h = w.health(counts, 10.0)
    assert h.level == WARN
    assert h.message == ('3 rejected (most: /capture_data unacked_round, 2); '
                         'the last 0 s ago')
    assert h.value('rejected_total') == '3'
    assert h.value('/sync_time accepted') == '40'
    assert w.health(counts, 69.0).level == WARN
    h = w.health(counts, 71.0)
    assert h.level == OK
    assert h.message == ('3 rejected (most: /capture_data unacked_round, 2); '
                         'none in the last 60 s')
    counts['/capture_data malformed'] += 1
    assert w.health(counts, 80.0).level == WARN


def test_health_value_of_a_missing_key():
    with pytest.raises(KeyError):
        Health(OK, '').value('x')
