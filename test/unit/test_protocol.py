"""hri_sync.wire.protocol: the CM's round and the CPM's schedule."""

import math

import pytest

from hri_sync.clock.model import ClockModel
from hri_sync.clock.sync import ClockStatus
from hri_sync.client_process.schedule import (ClientSchedule, Late, Scheduled,
                                              SyncReply)
from hri_sync.control.round import ControlRound
from hri_sync.wire.protocol import (Abort, Ack, Capture, ProtocolError,
                                    StrAftPolicy)

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
# Measured at local 95 (+/- 1 ms), growing 0.1 ms/s; global = local + 2.
MODEL = ClockModel(local_ref=95.0, offset=2.0, uncertainty=0.001,
                   drift_bound=1e-4)
FRESH = ClockStatus(MODEL, '', 3)
DOWN = 'time server 127.0.0.1:11123 did not answer within 0.50 s'
NO_MODEL = ClockStatus(ClockModel(), DOWN, 0)


def acked(client, round_id=5):
    """A schedule that ACKed ``round_id`` at local 98."""
    s = ClientSchedule(client, max_uncertainty=0.005)
    assert s.on_sync(round_id, 98.0, 98.0, FRESH).ok
    return s


# The ACK/NACK rule (a model, its uncertainty now, the measurement's error)

def test_fresh_clock_acks_with_its_numbers_at_the_answer():
    s = ClientSchedule('alice', max_uncertainty=0.005)
    reply = s.on_sync(5, 97.5, 98.0, FRESH)
    assert reply == SyncReply(
        round=5, client_id='alice', ok=True, reason='', offset=2.0,
        uncertainty=pytest.approx(0.0013, abs=1e-15), drift=0.0,
        sync_received=99.5, stamp=100.0)
    assert s.acked_round == 5


@pytest.mark.parametrize('error, reason', [(DOWN, DOWN),
                                           ('', 'no clock model yet')])
def test_no_model_nacks_with_the_measurements_error(error, reason):
    s = ClientSchedule('alice', max_uncertainty=0.005)
    reply = s.on_sync(5, 97.5, 98.0, ClockStatus(ClockModel(), error, 0))
    assert (reply.ok, reply.reason) == (False, reason)
    for x in (reply.offset, reply.uncertainty, reply.drift,
              reply.sync_received, reply.stamp):
        assert math.isnan(x)
    assert s.acked_round is None


def test_a_fresh_but_too_uncertain_clock_nacks():
    s = ClientSchedule('alice', max_uncertainty=0.001)
    reply = s.on_sync(5, 98.0, 98.0, FRESH)          # 1.3 ms > 1 ms
    assert not reply.ok
    assert reply.reason == ('offset uncertainty 1.30 ms exceeds '
                            '~max_uncertainty 1.00 ms')
    assert reply.uncertainty == pytest.approx(0.0013, abs=1e-15)
    assert s.acked_round is None


def test_holdover_acks_until_the_grown_uncertainty_passes_the_limit():
    # The time server stopped answering after the measurement at 95: the
    # bound grows 0.1 ms/s from 1 ms and passes 5 ms at local 135.
    s = ClientSchedule('alice', max_uncertainty=0.005)
    held = ClockStatus(MODEL, DOWN, 3)
    reply = s.on_sync(5, 104.9, 105.0, held)
    assert reply.ok
    assert reply.reason == ('holdover: no good sync for 10.0 s (%s); '
                            'uncertainty 2.000 ms' % DOWN)
    assert reply.stamp == 107.0
    assert s.acked_round == 5
    assert s.on_sync(6, 134.9, 134.9, held).ok
    reply = s.on_sync(7, 135.1, 135.1, held)
    assert not reply.ok
    assert reply.reason == ('offset uncertainty 5.01 ms exceeds '
                            '~max_uncertainty 5.00 ms; no good sync for '
                            '40.1 s: %s' % DOWN)
    assert reply.offset == 2.0      # the model is still reported
    assert s.acked_round is None


@pytest.mark.parametrize('bad', [0.0, -0.001, math.nan])
def test_max_uncertainty_must_be_positive(bad):
    with pytest.raises(ProtocolError, match='~max_uncertainty'):
        ClientSchedule('alice', max_uncertainty=bad)


# Capture orders


def test_scheduled_in_global_and_local_time():
    s = acked('alice')
    order = s.on_capture(capture(), 100.125, CLOCK)
    assert order == Scheduled(round=5, start=100.5, end=102.5,
                              local_start=98.5, lead=0.375)
    assert not s.ignored


def test_scheduled_local_start_follows_the_drift():
    clock = ClockModel(local_ref=90.0, offset=2.0, drift=1e-3)
    s = acked('alice')
    order = s.on_capture(capture(), 100.0, clock)
    assert clock.to_global(order.local_start) == pytest.approx(100.5,
                                                               abs=1e-12)


def test_order_after_the_start_is_late_not_captured():
    s = acked('alice')
    order = s.on_capture(capture(), 100.75, CLOCK)
    assert isinstance(order, Late)
    assert (order.round, order.start, order.end, order.lateness) == (
        5, 100.5, 102.5, 0.25)
    assert order.reason == ('capture_data for round 5 arrived 250.0 ms '
                            'after the window start; not capturing out of '
                            'step')


def test_order_exactly_at_the_start_is_late():
    s = acked('alice')
    order = s.on_capture(capture(), 100.5, CLOCK)
    assert isinstance(order, Late) and order.lateness == 0.0


def test_one_capture_per_ack():
    s = acked('alice')
    assert isinstance(s.on_capture(capture(), 100.0, CLOCK), Scheduled)
    assert s.on_capture(capture(), 100.0, CLOCK) is None
    assert dict(s.ignored) == {'unacked_round': 1}


def test_old_round_capture_is_ignored_and_counted():
    s = acked('alice', 6)
    assert s.on_capture(capture(round_id=5), 100.0, CLOCK) is None
    assert s.on_capture(capture(round_id=7), 100.0, CLOCK) is None
    assert dict(s.ignored) == {'unacked_round': 2}
    # The round we ACKed still gets its order.
    assert isinstance(s.on_capture(capture(round_id=6), 100.0, CLOCK),
                      Scheduled)


def test_capture_for_a_round_we_refused_is_ignored():
    s = acked('alice')
    s.on_sync(6, 98.0, 98.0, NO_MODEL)   # a NACK forgets the earlier round
    assert s.on_capture(capture(round_id=6), 100.0, CLOCK) is None
    assert s.on_capture(capture(round_id=5), 100.0, CLOCK) is None
    assert s.ignored['unacked_round'] == 2


def test_capture_before_any_sync_is_ignored():
    s = ClientSchedule('alice', max_uncertainty=0.005)
    assert s.on_capture(capture(), 100.0, CLOCK) is None
    assert s.ignored['unacked_round'] == 1


def test_capture_for_other_clients_is_ignored_as_not_a_participant():
    s = ClientSchedule('carol', max_uncertainty=0.005)
    assert s.on_capture(capture(), 100.0, CLOCK) is None
    assert dict(s.ignored) == {'not_a_participant': 1}


def test_a_round_without_a_client_that_acked_it_is_told_apart():
    """The client ACKed, the round went on without it: the server does
    not list it (the CPM warns, naming the listed clients)."""
    s = acked('carol')
    assert s.on_capture(capture(), 100.0, CLOCK) is None
    assert dict(s.ignored) == {'acked_not_a_participant': 1}


@pytest.mark.parametrize('fields', [
    {'str_aft': math.nan}, {'str_aft': -0.5}, {'str_aft': math.inf},
    {'dur': 0.0}, {'dur': -1.0}, {'dur': math.nan}, {'dur': math.inf},
    {'cr_t': math.nan}, {'cr_t': math.inf},
])
def test_malformed_capture_is_ignored_and_counted(fields):
    s = acked('alice')
    assert s.on_capture(capture(**fields), 100.0, CLOCK) is None
    assert dict(s.ignored) == {'malformed': 1}
    # A well-formed order for the same round is still taken.
    assert isinstance(s.on_capture(capture(), 100.0, CLOCK), Scheduled)


# -- Capture.from_msg --------------------------------------------------------

class FakeTime:
    def __init__(self, secs):
        self.secs = secs

    def to_sec(self):
        return self.secs


class FakeHeader:
    def __init__(self, stamp):
        self.stamp, self.frame_id = stamp, ''


class FakeCaptureData:
    def __init__(self, cr_t):
        self.header = FakeHeader(cr_t)
        self.round, self.str_aft, self.dur = 4, 0.5, 2.0
        self.clients = ('alice', 'bob')


@pytest.mark.parametrize('cr_t', [FakeTime(100.25), 100.25])
def test_capture_from_a_message_with_a_ros_time_or_seconds(cr_t):
    c = Capture.from_msg(FakeCaptureData(cr_t))
    assert c == Capture(4, 100.25, 0.5, 2.0, ['alice', 'bob'])
    assert (c.start, c.end) == (100.75, 102.75)
