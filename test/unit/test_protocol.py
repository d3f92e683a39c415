"""hri_sync.timing.protocol: the CM's round and the CPM's schedule."""

import math

import pytest

from hri_sync.timing.clock import ClockModel
from hri_sync.timing.protocol import (Abort, Ack, Capture, ClientSchedule,
                                      ControlRound, Late, ProtocolError,
                                      Scheduled, StrAftPolicy)

CLIENTS = ['alice', 'bob', 'carol']


def ack(client, ok=True, round_id=3, reason='', uncertainty=0.001,
        latency=0.01):
    return Ack(round_id, client, ok, reason, 0.0, uncertainty, latency)


def fixed(value=0.5):
    return StrAftPolicy(fixed=value)


# -- ControlRound ------------------------------------------------------------

def test_all_ack_gives_capture_with_every_client():
    rnd = ControlRound(3, CLIENTS, 2.0, fixed(0.5))
    for c in reversed(CLIENTS):
        assert not rnd.all_answered()
        assert rnd.on_ack(ack(c))
    assert rnd.all_answered()
    order = rnd.close(100.0)
    assert order == Capture(3, 100.0, 0.5, 2.0, CLIENTS)   # clients order
    assert (order.start, order.end) == (100.5, 102.5)
    assert rnd.done and not rnd.ignored


def test_missing_ack_aborts_naming_the_client():
    rnd = ControlRound(3, CLIENTS, 2.0, fixed())
    rnd.on_ack(ack('alice'))
    rnd.on_ack(ack('carol'))
    assert rnd.missing == ['bob'] and not rnd.all_answered()
    order = rnd.close(100.0)
    assert order == Abort(3, 'round 3 aborted: 2 of 3 clients synced, 3 '
                          'needed: no ACK from bob', ['alice', 'carol'], [],
                          ['bob'])


def test_refused_ack_aborts_with_the_clients_reason():
    rnd = ControlRound(3, CLIENTS, 2.0, fixed())
    rnd.on_ack(ack('alice'))
    rnd.on_ack(ack('bob', ok=False,
                   reason='time server 10.0.0.1:123 did not answer'))
    rnd.on_ack(ack('carol', ok=False))
    assert rnd.all_answered()
    order = rnd.close(100.0)
    assert isinstance(order, Abort)
    assert order.reason == (
        'round 3 aborted: 1 of 3 clients synced, 3 needed: bob refused '
        '(time server 10.0.0.1:123 did not answer); carol refused '
        '(no reason given)')
    assert (order.acked, order.refused, order.missing) == (
        ['alice'], ['bob', 'carol'], [])


def test_refused_and_missing_both_named():
    rnd = ControlRound(7, CLIENTS, 1.0, fixed(), min_clients=2)
    rnd.on_ack(Ack(7, 'carol', False, 'uncertainty too large'))
    order = rnd.close(5.0)
    assert order.reason == (
        'round 7 aborted: 0 of 3 clients synced, 2 needed: carol refused '
        '(uncertainty too large); no ACK from alice, bob')


def test_quorum_goes_on_without_the_missing_client():
    rnd = ControlRound(3, CLIENTS, 2.0, fixed(0.5), min_clients=2)
    rnd.on_ack(ack('carol'))
    rnd.on_ack(ack('alice'))
    order = rnd.close(100.0)
    assert order == Capture(3, 100.0, 0.5, 2.0, ['alice', 'carol'])


def test_quorum_goes_on_without_a_refusing_client():
    rnd = ControlRound(3, CLIENTS, 2.0, fixed(0.5), min_clients=2)
    rnd.on_ack(ack('alice'))
    rnd.on_ack(ack('bob', ok=False, reason='unreachable'))
    rnd.on_ack(ack('carol'))
    assert rnd.close(1.0).clients == ['alice', 'carol']


def test_quorum_not_reached_aborts():
    rnd = ControlRound(3, CLIENTS, 2.0, fixed(), min_clients=2)
    rnd.on_ack(ack('alice'))
    order = rnd.close(100.0)
    assert isinstance(order, Abort)
    assert order.reason == ('round 3 aborted: 1 of 3 clients synced, 2 '
                            'needed: no ACK from bob, carol')


def test_old_future_unknown_and_duplicate_acks_are_ignored_and_counted():
    rnd = ControlRound(3, CLIENTS, 2.0, fixed())
    assert not rnd.on_ack(ack('alice', round_id=2))
    assert not rnd.on_ack(ack('alice', round_id=1))
    assert not rnd.on_ack(ack('alice', round_id=4))
    assert not rnd.on_ack(ack('mallory'))
    assert rnd.on_ack(ack('bob', ok=False, reason='first answer'))
    assert not rnd.on_ack(ack('bob', ok=True))      # the first answer holds
    assert rnd.refused == ['bob'] and rnd.acked == []
    assert rnd.missing == ['alice', 'carol']
    assert dict(rnd.ignored) == {'old_round': 2, 'future_round': 1,
                                 'unknown_client': 1, 'duplicate_ack': 1}


def test_ack_after_close_is_ignored_and_counted():
    rnd = ControlRound(3, CLIENTS, 2.0, fixed())
    rnd.on_ack(ack('alice'))
    order = rnd.close(10.0)
    assert not rnd.on_ack(ack('bob'))
    assert rnd.missing == ['bob', 'carol']
    assert rnd.ignored['after_close'] == 1
    assert order.missing == ['bob', 'carol']


@pytest.mark.parametrize('clients, dur, min_clients, message', [
    ([], 1.0, None, '~clients is empty'),
    (['a', 'b', 'a'], 1.0, None, '~clients lists a client twice: a,b,a'),
    (['a'], 0.0, None, '~dur must be > 0 s, got 0.0'),
    (['a'], -1.0, None, '~dur must be > 0 s'),
    (['a'], math.nan, None, '~dur must be > 0 s'),
    (['a'], math.inf, None, '~dur must be > 0 s'),
    (['a'], '2', None, "~dur must be > 0 s, got '2'"),
    (['a', 'b'], 1.0, 0, r'~min_clients must be within 1\.\.2, got 0'),
    (['a', 'b'], 1.0, 3, r'~min_clients must be within 1\.\.2, got 3'),
])
def test_bad_round_params_raise_protocol_error(clients, dur, min_clients,
                                               message):
    with pytest.raises(ProtocolError, match=message):
        ControlRound(1, clients, dur, fixed(), min_clients)


# -- StrAftPolicy ------------------------------------------------------------

@pytest.mark.parametrize('value, expected', [
    ('auto', None), (' AUTO ', None), ('0.75', 0.75), (2, 2.0), (0.5, 0.5)])
def test_str_aft_parse(value, expected):
    p = StrAftPolicy.parse(value, margin=0.125)
    assert p.fixed == expected and p.margin == 0.125


@pytest.mark.parametrize('value', ['soon', None, '', 0, -0.5, 'nan',
                                   math.inf])
def test_str_aft_parse_refuses_bad_values(value):
    with pytest.raises(ProtocolError, match='~str_aft must be'):
        StrAftPolicy.parse(value)


def test_fixed_str_aft_ignores_latency_but_records_it():
    p = StrAftPolicy.parse(0.5)
    assert p.choose([ack('a', latency=2.0, uncertainty=0.1)]) == 0.5
    assert p.latencies == [2.0]


def test_auto_str_aft_from_latency_uncertainty_and_margin():
    p = StrAftPolicy.parse('auto', margin=0.25)
    acks = [ack('a', latency=0.01, uncertainty=0.001),
            ack('b', latency=0.02, uncertainty=0.003),
            ack('c', latency=math.nan, uncertainty=0.002)]
    # 3 x 20 ms + 2 x 3 ms + 250 ms
    assert p.choose(acks) == pytest.approx(0.316, abs=1e-12)
    assert p.latencies == [0.01, 0.02]


def test_auto_str_aft_remembers_recent_rounds_only():
    p = StrAftPolicy(fixed=None, margin=0.0, latency_factor=1.0,
                     minimum=0.0, history=3)
    assert p.choose([ack('a', latency=0.5, uncertainty=0.0)]) == 0.5
    # A later quick round still allows for the slow one seen before.
    assert p.choose([ack('a', latency=0.125, uncertainty=0.0)]) == 0.5
    p.choose([ack('a', latency=0.125, uncertainty=0.0),
              ack('b', latency=0.25, uncertainty=0.0)])
    assert p.latencies == [0.125, 0.125, 0.25]
    assert p.choose([ack('a', latency=0.0625, uncertainty=0.0)]) == 0.25


def test_auto_str_aft_never_below_minimum():
    p = StrAftPolicy(fixed=None, margin=0.0, minimum=0.1)
    assert p.choose([ack('a', latency=-0.01, uncertainty=0.0)]) == 0.1
    assert p.choose([]) == 0.1


def test_auto_str_aft_stays_finite_with_an_unknown_uncertainty():
    # An ACK (from a foreign or buggy client) without a finite uncertainty
    # must not turn STR_AFT into NaN, which every client would refuse.
    p = StrAftPolicy(fixed=None, margin=0.25)
    for acks in ([ack('a', uncertainty=math.nan, latency=0.01),
                  ack('b', uncertainty=0.002, latency=0.01)],
                 [ack('b', uncertainty=0.002, latency=0.01),
                  ack('a', uncertainty=math.nan, latency=0.01)]):
        assert p.choose(acks) == pytest.approx(0.03 + 0.004 + 0.25,
                                               abs=1e-12)


def test_auto_policy_in_a_round():
    rnd = ControlRound(1, ['a', 'b'], 1.0, StrAftPolicy.parse('auto', 0.25),
                       min_clients=1)
    rnd.on_ack(Ack(1, 'a', True, '', 0.0, 0.0005, 0.01))
    rnd.on_ack(Ack(1, 'b', False, 'x', math.nan, math.nan, math.nan))
    order = rnd.close(10.0)
    assert order.clients == ['a']
    assert order.str_aft == pytest.approx(0.03 + 0.001 + 0.25, abs=1e-12)


# -- ClientSchedule ----------------------------------------------------------

def capture(round_id=5, cr_t=100.0, str_aft=0.5, dur=2.0,
            clients=('alice', 'bob')):
    return Capture(round_id, cr_t, str_aft, dur, list(clients))


CLOCK = ClockModel(offset=2.0)   # global = local + 2


def test_scheduled_in_global_and_local_time():
    s = ClientSchedule('alice')
    s.on_sync(5, True)
    order = s.on_capture(capture(), 100.125, CLOCK)
    assert order == Scheduled(round=5, start=100.5, end=102.5,
                              local_start=98.5, lead=0.375)
    assert not s.ignored


def test_scheduled_local_start_follows_the_drift():
    clock = ClockModel(local_ref=90.0, offset=2.0, drift=1e-3)
    s = ClientSchedule('alice')
    s.on_sync(5, True)
    order = s.on_capture(capture(), 100.0, clock)
    assert clock.to_global(order.local_start) == pytest.approx(100.5,
                                                               abs=1e-12)


def test_order_after_the_start_is_late_not_captured():
    s = ClientSchedule('alice')
    s.on_sync(5, True)
    order = s.on_capture(capture(), 100.75, CLOCK)
    assert isinstance(order, Late)
    assert (order.round, order.start, order.end, order.lateness) == (
        5, 100.5, 102.5, 0.25)
    assert order.reason == ('capture_data for round 5 arrived 250.0 ms '
                            'after the window start; not capturing out of '
                            'step')


def test_order_exactly_at_the_start_is_late():
    s = ClientSchedule('alice')
    s.on_sync(5, True)
    order = s.on_capture(capture(), 100.5, CLOCK)
    assert isinstance(order, Late) and order.lateness == 0.0


def test_one_capture_per_ack():
    s = ClientSchedule('alice')
    s.on_sync(5, True)
    assert isinstance(s.on_capture(capture(), 100.0, CLOCK), Scheduled)
    assert s.on_capture(capture(), 100.0, CLOCK) is None
    assert dict(s.ignored) == {'unacked_round': 1}


def test_old_round_capture_is_ignored_and_counted():
    s = ClientSchedule('alice')
    s.on_sync(6, True)
    assert s.on_capture(capture(round_id=5), 100.0, CLOCK) is None
    assert s.on_capture(capture(round_id=7), 100.0, CLOCK) is None
    assert dict(s.ignored) == {'unacked_round': 2}
    # The round we ACKed still gets its order.
    assert isinstance(s.on_capture(capture(round_id=6), 100.0, CLOCK),
                      Scheduled)


def test_capture_for_a_round_we_refused_is_ignored():
    s = ClientSchedule('alice')
    s.on_sync(5, True)
    s.on_sync(6, False)        # the NACK also forgets the earlier round
    assert s.on_capture(capture(round_id=6), 100.0, CLOCK) is None
    assert s.on_capture(capture(round_id=5), 100.0, CLOCK) is None
    assert s.ignored['unacked_round'] == 2


def test_capture_before_any_sync_is_ignored():
    s = ClientSchedule('alice')
    assert s.on_capture(capture(), 100.0, CLOCK) is None
    assert s.ignored['unacked_round'] == 1


def test_capture_for_other_clients_is_ignored_as_not_a_participant():
    s = ClientSchedule('carol')
    s.on_sync(5, True)
    assert s.on_capture(capture(), 100.0, CLOCK) is None
    assert dict(s.ignored) == {'not_a_participant': 1}


@pytest.mark.parametrize('fields', [
    {'str_aft': math.nan}, {'str_aft': -0.5}, {'str_aft': math.inf},
    {'dur': 0.0}, {'dur': -1.0}, {'dur': math.nan}, {'dur': math.inf},
    {'cr_t': math.nan}, {'cr_t': math.inf},
])
def test_malformed_capture_is_ignored_and_counted(fields):
    s = ClientSchedule('alice')
    s.on_sync(5, True)
    assert s.on_capture(capture(**fields), 100.0, CLOCK) is None
    assert dict(s.ignored) == {'malformed': 1}
    # A well-formed order for the same round is still taken.
    assert isinstance(s.on_capture(capture(), 100.0, CLOCK), Scheduled)
