"""hri_sync.control.session: the CM's session of rounds on a fake clock."""

import math
from types import SimpleNamespace

import pytest

from hri_sync.control.session import (ABORTED, CAPTURING, DECIDED, IDLE,
                                      NO_DECISION, SHUTDOWN, SYNCING,
                                      ClientsWait, ControlSession, Log,
                                      Refused, RoundEnd, StatusUpdate,
                                      SyncOrder)
from hri_sync.wire.protocol import Capture, ProtocolError, StrAftPolicy

CLIENTS = ['alice', 'bob', 'carol']


class FakeClock:
    """Global time that moves only when told."""

    def __init__(self, t=1000.0):
        self.t = t

    def now(self):
        return self.t

    def advance(self, dt):
        self.t += dt
        return self.t


def session(clients=CLIENTS, str_aft=0.5, **kw):
    kw.setdefault('ack_timeout', 3.0)
    kw.setdefault('decision_timeout', 5.0)
    policy = StrAftPolicy.parse(str_aft, margin=0.25)
    return ControlSession(clients, 2.0, policy, **kw)


def ack(client, round_id=1, ok=True, reason='', sync_received=1000.01,
        uncertainty=0.001):
    return SimpleNamespace(round=round_id, client_id=client, ok=ok,
                           reason=reason, offset=0.0 if ok else math.nan,
                           uncertainty=uncertainty if ok else math.nan,
                           sync_received=sync_received)


def of(kind, outputs):
    return [o for o in outputs if isinstance(o, kind)]


def logs(outputs, level=None):
    return [o.text for o in of(Log, outputs)
            if level is None or o.level == level]


def poll_until(s, clock, t, step=0.1):
    """Poll every ``step`` s up to global ``t``; all outputs."""
    out = []
    while clock.t < t - 1e-9:
        out += s.poll(clock.advance(min(step, t - clock.t)))
    return out


def test_all_acks_give_a_capture_order_and_the_decision_ends_the_round():
    clock = FakeClock()
    s = session()
    out = s.start(clock.now())
    assert out == [StatusUpdate(1, SYNCING, '', [], [], CLIENTS, 1000.0),
                   SyncOrder(1, 1000.0)]
    assert s.phase == SYNCING and not s.idle
    clock.advance(0.02)
    for c in ('carol', 'bob'):
        assert logs(s.on_ack(ack(c)), 'info') == [
            'round 1: %s ACK offset +0.000000 s +/- 1.000 ms' % c]
        assert s.poll(clock.now()) == []
    s.on_ack(ack('alice'))
    assert s.phase == SYNCING          # the next poll closes the ACKs
    assert of(Capture, s.poll(clock.now())) == [
        Capture(1, 1000.02, 0.5, 2.0, CLIENTS)]      # in ~clients order
    assert s.phase == CAPTURING
    assert s.deadline == pytest.approx(1000.02 + 2.5 + 5.0)
    assert s.on_decision(1) == []
    out = s.poll(clock.advance(3.0))
    assert out == [RoundEnd(1, DECIDED, 'round 1 decided')]
    assert out[0].ok and s.idle and s.result(1) == out[0]


def test_capture_order_outputs_status_and_log():
    clock = FakeClock()
    s = session()
    s.start(clock.now())
    for c in CLIENTS:
        s.on_ack(ack(c))
    out = s.poll(clock.advance(0.05))
    assert of(Capture, out) == [Capture(1, 1000.05, 0.5, 2.0, CLIENTS)]
    assert of(StatusUpdate, out) == [
        StatusUpdate(1, CAPTURING, '', CLIENTS, [], [], 1000.05)]
    assert logs(out, 'info') == [
        'round 1: capture_data CR_T=1000.050000 STR_AFT=0.500 s DUR=2.000 '
        's for alice,bob,carol']


def test_auto_str_aft_from_the_acks_dispatch_latency():
    clock = FakeClock()
    s = session(str_aft='auto')
    s.start(clock.now())              # sync_time stamped 1000.0
    s.on_ack(ack('alice', sync_received=1000.010, uncertainty=0.001))
    s.on_ack(ack('bob', sync_received=1000.040, uncertainty=0.003))
    s.on_ack(ack('carol', sync_received=1000.020, uncertainty=0.002))
    order = of(Capture, s.poll(clock.advance(0.05)))[0]
    # 3 x 40 ms + 2 x 3 ms + 250 ms margin
    assert order.str_aft == pytest.approx(0.376, abs=1e-9)
    assert s.policy.latencies == pytest.approx([0.010, 0.040, 0.020])


def test_a_refusal_has_no_latency():
    clock = FakeClock()
    s = session(str_aft='auto', min_clients=2)
    s.start(clock.now())
    s.on_ack(ack('alice', sync_received=1000.010))
    s.on_ack(ack('bob', ok=False, reason='unreachable',
                 sync_received=1e9))
    s.on_ack(ack('carol', sync_received=1000.010))
    s.poll(clock.advance(0.05))
    assert s.policy.latencies == pytest.approx([0.010, 0.010])


def test_missing_ack_aborts_at_the_ack_timeout_naming_the_client():
    clock = FakeClock()
    s = session()
    s.start(clock.now())
    s.on_ack(ack('alice'))
    s.on_ack(ack('carol'))
    assert poll_until(s, clock, 1002.9) == []     # still waiting
    assert s.phase == SYNCING
    out = poll_until(s, clock, 1003.0)
    reason = ('round 1 aborted: 2 of 3 clients synced, 3 needed: no ACK '
              'from bob')
    assert out == [Log('error', reason),
                   StatusUpdate(1, ABORTED, reason, ['alice', 'carol'], [],
                                ['bob'], 1003.0),
                   RoundEnd(1, ABORTED, reason)]
    assert not out[-1].ok and s.idle
    assert of(Capture, out) == []


def test_refused_ack_aborts_as_soon_as_everyone_answered():
    clock = FakeClock()
    s = session()
    s.start(clock.now())
    s.on_ack(ack('alice'))
    out = s.on_ack(ack('bob', ok=False, reason='time server 10.0.0.1:123 '
                       'did not answer'))
    assert logs(out) == ['round 1: bob NACK offset +nan s +/- nan ms (time '
                         'server 10.0.0.1:123 did not answer)']
    s.on_ack(ack('carol'))
    out = s.poll(clock.advance(0.1))
    end = of(RoundEnd, out)[0]
    assert end.outcome == ABORTED
    assert end.message == (
        'round 1 aborted: 2 of 3 clients synced, 3 needed: bob refused '
        '(time server 10.0.0.1:123 did not answer)')
    status = of(StatusUpdate, out)[0]
    assert (status.acked, status.refused, status.missing) == (
        ['alice', 'carol'], ['bob'], [])


def test_quorum_goes_on_without_the_missing_client_at_the_timeout():
    clock = FakeClock()
    s = session(min_clients=2)
    s.start(clock.now())
    s.on_ack(ack('alice'))
    s.on_ack(ack('carol'))
    assert poll_until(s, clock, 1002.9) == []
    out = poll_until(s, clock, 1003.0)
    assert of(Capture, out) == [Capture(1, 1003.0, 0.5, 2.0,
                                        ['alice', 'carol'])]
    assert of(StatusUpdate, out)[0].reason == '(quorum without bob)'
    assert logs(out, 'info')[0].endswith('for alice,carol (quorum without '
                                         'bob)')
    assert s.phase == CAPTURING


def test_quorum_not_reached_aborts():
    clock = FakeClock()
    s = session(min_clients=2)
    s.start(clock.now())
    s.on_ack(ack('alice'))
    s.on_ack(ack('bob', ok=False, reason='uncertainty too large'))
    out = poll_until(s, clock, 1003.0)
    assert of(RoundEnd, out) == [RoundEnd(
        1, ABORTED, 'round 1 aborted: 1 of 3 clients synced, 2 needed: bob '
        'refused (uncertainty too large); no ACK from carol')]


def test_no_server_clock_aborts_at_once():
    clock = FakeClock()
    s = session()
    out = s.start(clock.now(), clock_ok=False,
                  clock_error='time server 127.0.0.1:11123 did not answer')
    reason = ('round 1 aborted: the server cannot reach its time server: '
              'time server 127.0.0.1:11123 did not answer')
    assert of(SyncOrder, out) == []
    assert logs(out, 'error') == [reason]
    status = of(StatusUpdate, out)[0]
    assert (status.round, status.state, status.reason) == (1, ABORTED,
                                                           reason)
    assert status.missing == CLIENTS and math.isnan(status.stamp)
    assert of(RoundEnd, out) == [RoundEnd(1, ABORTED, reason)]
    assert s.idle and s.round == 1
    # The next round has the next number.
    assert of(SyncOrder, s.start(clock.now())) == [SyncOrder(2, 1000.0)]


def captured(clock, s=None):
    s = s or session()
    s.start(clock.now())
    for c in CLIENTS:
        s.on_ack(ack(c, round_id=s.round))
    assert of(Capture, s.poll(clock.advance(0.1)))
    return s


def test_decision_timeout_after_the_window_end():
    clock = FakeClock()
    s = captured(clock)
    # Window [1000.6, 1002.6); the decision is due by 1007.6.
    assert poll_until(s, clock, 1007.5) == []
    out = poll_until(s, clock, 1007.6)
    assert out == [Log('error', 'round 1: no decision within 5.0 s of the '
                       'window end'),
                   RoundEnd(1, NO_DECISION, 'round 1 captured, no decision')]
    assert s.idle
    # A decision that comes later is said to be late, and changes nothing.
    assert logs(s.on_decision(1), 'warn') == [
        'round 1: its decision arrived after the control module stopped '
        'waiting for it']
    assert s.ignored['after_deadline'] == 1
    assert s.result(1).outcome == NO_DECISION


def test_a_decision_for_another_round_is_ignored():
    clock = FakeClock()
    s = session(first_round=5)
    s.start(clock.now())
    # Before the capture order, even this round's decision is ignored.
    assert logs(s.on_decision(5), 'warn') == [
        'decision for round 5 before its capture order: ignored']
    for c in CLIENTS:
        s.on_ack(ack(c, round_id=5))
    s.poll(clock.advance(0.1))
    assert logs(s.on_decision(6), 'warn') == [
        'decision for round 6, which has not started (last round 5): '
        'ignored']
    assert logs(s.on_decision(4), 'debug') == [
        'decision for round 4 (ended: unknown): nothing to do']
    assert poll_until(s, clock, 1007.6)[-1].outcome == NO_DECISION
    assert dict(s.ignored) == {'before_capture': 1, 'future_round': 1,
                               'old_round': 1}


def test_decision_of_an_aborted_round_is_only_noted():
    clock = FakeClock()
    s = session()
    s.start(clock.now(), clock_ok=False, clock_error='x')
    assert of(Log, s.on_decision(1)) == [
        Log('debug', 'decision for round 1 (ended: aborted): nothing to do')]


def test_shutdown_while_waiting_for_the_decision():
    clock = FakeClock()
    s = captured(clock)
    out = s.shutdown()
    assert out == [Log('warn', 'round 1: shut down before its decision'),
                   RoundEnd(1, SHUTDOWN, 'round 1: shut down')]
    assert s.result(1).outcome == SHUTDOWN
    assert s.start(clock.now()) == [
        Refused('the control module is shutting down')]
    assert not s.idle and s.shutdown() == []


def test_shutdown_while_waiting_for_acks():
    clock = FakeClock()
    s = session()
    s.start(clock.now())
    out = s.shutdown()
    assert logs(out) == ['round 1: shut down before its capture order']
    assert of(RoundEnd, out)[0].outcome == SHUTDOWN
    assert s.poll(clock.advance(10.0)) == []


def test_shutdown_when_idle_is_quiet():
    s = session()
    assert s.shutdown() == []


def test_a_second_start_is_refused_while_a_round_runs():
    clock = FakeClock()
    s = captured(clock)
    refused = s.start(clock.now())
    assert refused == [Refused('round 1 is still running')]
    assert not refused[0].ok
    assert s.round == 1


def test_rounds_are_numbered_on():
    clock = FakeClock()
    s = session(first_round=7)
    assert s.round == 6
    for expected in (7, 8, 9):
        s.start(clock.now())
        assert s.round == expected
        for c in CLIENTS:
            s.on_ack(ack(c, round_id=expected))
        s.poll(clock.advance(0.1))
        s.on_decision(expected)
        assert s.poll(clock.advance(0.1))[-1] == RoundEnd(
            expected, DECIDED, 'round %d decided' % expected)


def test_stray_acks_are_logged_and_ignored():
    clock = FakeClock()
    s = session()
    assert logs(s.on_ack(ack('alice')), 'warn') == [
        'ACK from alice for round 1 before any round: ignored']
    s.start(clock.now())
    assert logs(s.on_ack(ack('alice', round_id=0)), 'warn') == [
        "ACK from alice for round 0 ignored (round 1 open; ignored so far: "
        "{'old_round': 1})"]
    assert logs(s.on_ack(ack('alicia')), 'warn') == [
        "ACK for round 1 ignored: unknown client 'alicia': valid: alice, "
        "bob, carol; did you mean 'alice'? (~clients)"]
    assert dict(s.current.ignored) == {'old_round': 1, 'unknown_client': 1}
    for c in CLIENTS:
        s.on_ack(ack(c))
    s.poll(clock.advance(0.1))
    # After the round closed, a late ACK is counted, not acted on.
    s.on_ack(ack('alice'))
    assert s.current.ignored['duplicate_ack'] == 1
    assert s.phase == CAPTURING and s.order.clients == CLIENTS


def test_idle_poll_does_nothing():
    s = session()
    assert s.poll(1e9) == [] and s.phase == IDLE


@pytest.mark.parametrize('kw, message', [
    ({'ack_timeout': 0.0}, '~ack_timeout must be > 0 s'),
    ({'ack_timeout': math.nan}, '~ack_timeout must be > 0 s'),
    ({'decision_timeout': -1.0}, '~decision_timeout must be > 0 s'),
    ({'first_round': 0}, '~first_round must be >= 1, got 0'),
    ({'min_clients': 4}, r'~min_clients must be within 1\.\.3'),
    ({'clients': []}, '~clients is empty'),
])
def test_bad_params_raise_protocol_error(kw, message):
    with pytest.raises(ProtocolError, match=message):
        session(**kw)


# --- ClientsWait: who the CM waits for before round 1 ------------------

def test_clients_wait_waits_for_silent_clients():
    w = ClientsWait(['a', 'b', 'c'])
    w.on_links({'a', 'b', 'c'}, 0.0)
    assert not w.settled and w.waiting() == ['a', 'b', 'c']
    w.on_state('a', True)
    w.on_state('b', True)
    assert w.waiting() == ['c']          # c never reported: a slow start
    assert w.describe(w.waiting()) == 'c (no clock_state yet)'
    w.on_state('c', True)
    assert w.settled and w.unsynced() == [] and w.unready() == []


def test_clients_wait_waits_for_the_cpms_links():
    w = ClientsWait(['a', 'music'])
    w.on_state('a', True)
    w.on_state('music', True)
    w.on_links({'a'}, 0.0)                    # music's CPM not connected yet
    assert w.waiting() == ['music'] and w.unready() == ['music']
    assert w.describe(['music']) == \
        'music (its CPM not connected to sync_time and sync_ack)'
    w.on_links({'a', 'music'}, 0.0)
    assert w.settled


def test_clients_wait_settles_on_repeated_failures_only():
    w = ClientsWait(['a', 'c'], failures=2)
    w.on_links({'a'}, 0.0)
    w.on_state('a', True)
    w.on_state('c', False, 'time server unreachable')
    assert w.waiting() == ['c']          # one failure may be transient
    w.on_state('c', False, 'time server unreachable')
    assert w.settled
    assert w.unsynced() == ['c']
    assert w.describe(w.unsynced()) == 'c (time server unreachable)'


def test_clients_wait_a_success_resets_the_failures():
    w = ClientsWait(['c'], failures=2)
    w.on_links({'c'}, 0.0)
    w.on_state('c', False, 'timeout')
    w.on_state('c', True)
    w.on_state('c', False, '')
    assert w.waiting() == ['c']
    assert w.describe(['c']) == 'c (no reason given)'
    w.on_state('x', True)                # not one of ours: ignored
    assert w.waiting() == ['c']


def test_clients_wait_waits_for_the_participants_dpms():
    w = ClientsWait(['a', 'b', 'dj_rob'], dpms=['a', 'b', 'ghost'])
    w.on_links({'a', 'b', 'dj_rob'}, 0.0)
    for c in ('a', 'b', 'dj_rob'):
        w.on_state(c, True)
    assert w.waiting() == ['a', 'b']     # clocks fine, DPMs not heard yet
    assert w.describe(['a']) == 'a (no dpm_state from its DPM yet)'
    w.on_dpm('a', 5)
    assert w.waiting() == ['b'] and w.unready() == ['b']
    w.on_dpm('b', 1)
    assert w.settled and w.unready() == []


def test_clients_wait_waits_for_a_sample_from_each_sensor():
    w = ClientsWait(['a', 'b'], dpms=['a', 'b'], sample_timeout=10.0)
    w.on_links({'a', 'b'}, 0.0)
    for c in ('a', 'b'):
        w.on_state(c, True)
        w.on_dpm(c, 0)                   # DPM up, its sensor not yet
    assert w.waiting() == ['a', 'b'] and w.unfed() == ['a', 'b']
    assert w.describe(['a']) == \
        'a (its DPM has received no sample from its sensor)'
    assert w.on_samples(0.0) == []
    w.on_dpm('a', 2)
    assert w.waiting() == ['b'] and w.unready() == ['b']
    assert w.on_samples(9.9) == []
    assert w.on_samples(10.0) == ['b']   # said once, then not waited for
    assert w.settled and w.unfed() == ['b'] and w.unready() == []
    assert w.on_samples(11.0) == []


def test_clients_wait_names_samples_the_dpm_refuses():
    w = ClientsWait(['a'], dpms=['a'])
    w.on_links({'a'}, 0.0)
    w.on_state('a', True)
    w.on_dpm('a', 0, 'a sensor_msgs/LaserScan on a sensor_msgs/Range topic')
    assert w.describe(['a']) == (
        "a (its DPM refuses its sensor's samples (a sensor_msgs/LaserScan "
        "on a sensor_msgs/Range topic))")


def test_clients_wait_times_samples_from_when_only_they_are_waited():
    w = ClientsWait(['a'], dpms=['a'], sample_timeout=10.0)
    assert w.on_samples(0.0) == []       # no clock yet: not timed
    w.on_state('a', True)
    w.on_dpm('a', 0)
    assert w.on_samples(50.0) == []      # links too: both timed from here
    assert w.on_links(set(), 50.0) == []
    assert w.on_samples(59.0) == [] and w.on_links(set(), 59.0) == []
    assert w.on_samples(60.0) == ['a'] and w.on_links(set(), 60.0) == ['a']
    assert w.settled


def test_clients_wait_a_failed_clock_settles_without_its_dpm():
    w = ClientsWait(['a'], failures=1, dpms=['a'])
    assert w.describe(['a']) == 'a (no clock_state yet)'
    w.on_state('a', False, 'time server unreachable')
    assert w.settled                     # it will NACK for its clock
    assert w.unready() == ['a'] and w.unsynced() == ['a']


def test_clients_wait_refuses_zero_failures():
    with pytest.raises(ValueError):
        ClientsWait(['a'], failures=0)


def test_clients_wait_can_stop_waiting_for_links():
    w = ClientsWait(['c'], dpms=['c'], link_timeout=10.0)
    assert w.on_links(set(), 100.0) == []   # nothing heard yet
    w.on_state('c', True)
    w.on_dpm('c', 3)
    assert w.on_links(set(), 101.0) == []   # only its link waited for
    assert w.on_links(set(), 110.9) == []
    assert w.waiting() == ['c']          # reached through a relay
    assert w.on_links(set(), 111.0) == ['c']   # said once
    assert w.settled and w.unlinked() == ['c']
    assert w.on_links(set(), 112.0) == []


def test_clients_wait_says_whom_it_waits_for_besides_links():
    w = ClientsWait(['a', 'b'])
    w.on_state('a', True)
    assert w.waiting(links=False) == ['b'] and w.waiting() == ['a', 'b']
    w.on_state('b', True)
    assert w.waiting(links=False) == [] and w.waiting() == ['a', 'b']
