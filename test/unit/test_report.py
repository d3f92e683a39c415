"""hri_sync.tools.round_summary: the round table, stand-in messages."""

import math
from types import SimpleNamespace as NS

import pytest

from hri_sync.tools.round_summary import round_report


def time_of(sec):
    return NS(to_sec=lambda: sec)


def kept(start, error, n=20, period=0.05, first=0.01):
    """(global stamp, true time, index) of samples with a clock error."""
    return [(start + first + k * period + error, start + first + k * period,
             k) for k in range(n)]


NACK_REASON = 'time server 127.0.0.1:11123 did not answer within 0.50 s'


@pytest.fixture
def round_msgs():
    capture = NS(clients=['alice', 'bob'],
                 header=NS(stamp=time_of(1000.0)),
                 str_aft=0.5, dur=2.0)
    acks = {'alice': NS(ok=True, offset=1.700123, uncertainty=0.00025,
                        reason=''),
            'bob': NS(ok=True, offset=-0.9, uncertainty=0.0005, reason=''),
            'carol': NS(ok=False, offset=math.nan, uncertainty=math.nan,
                        reason=NACK_REASON)}
    results = {'alice': NS(wake_lateness=0.00425, frames=40, status='ok',
                           value=2.5),
               'bob': NS(wake_lateness=0.0005, frames=39, status='partial',
                         value=1.25)}
    captured = {'alice': kept(1000.5, 0.0015), 'bob': kept(1000.5, -0.0005)}
    decision = NS(outcome='winner', winner=1, clients=['alice', 'bob'],
                  reason='alice scored highest (2.5)')
    return acks, capture, results, captured, decision


def test_full_round_table(round_msgs):
    acks, capture, results, captured, decision = round_msgs
    text, timings = round_report(4, acks, capture, results, captured,
                                 decision)
    lines = text.split('\n')
    assert lines[0] == 'round 4'
    assert lines[1] == ('  window: CR_T 1000.000000 + STR_AFT 0.500 s, '
                        'DUR 2.000 s (global start 1000.500000)')
    assert lines[2].split() == ['client', 'ack', 'offset', '[s]', 'unc',
                                '[ms]', 'clk', 'err', '[ms]', 'wake', '[ms]',
                                'frames', 'status', 'value']
    assert lines[3].split() == ['alice', 'ok', '+1.700123', '0.250',
                                '+1.500', '+4.250', '40', 'ok', '2.5']
    assert lines[4].split() == ['bob', 'ok', '-0.900000', '0.500', '-0.500',
                                '+0.500', '39', 'partial', '1.25']
    # The refused client is listed though it is not in the capture.
    assert lines[5].split() == ['carol', 'NACK'] + ['-'] * 7
    assert lines[6] == '      NACK reason: ' + NACK_REASON
    assert lines[7] == '  start skew across clients (true time): 2.000 ms'
    assert lines[8] == ('  decision: winner participant 1 (alice): alice '
                        'scored highest (2.5)')
    assert len(lines) == 9
    assert [t.client_id for t in timings] == ['alice', 'bob', 'carol']
    assert timings[0].clock_error == pytest.approx(0.0015, abs=1e-9)
    assert timings[1].first_index == 0 and timings[1].samples == 20
    assert math.isnan(timings[2].clock_error)


def test_no_capture_no_decision(round_msgs):
    acks, _, _, _, _ = round_msgs
    acks = {'bob': acks['bob'], 'alice': acks['alice']}
    text, timings = round_report(2, acks, None, {}, {}, None)
    lines = text.split('\n')
    assert lines[0] == 'round 2'
    assert [line.split()[0] for line in lines[2:4]] == ['alice', 'bob']
    assert lines[2].split()[4:] == ['-'] * 5     # no results, no samples
    assert lines[-1] == '  decision: none received'
    assert 'start skew' not in text              # nobody kept samples
    assert 'window' not in text
    assert len(timings) == 2


def test_no_winner_decision_names_nobody(round_msgs):
    acks, capture, results, captured, _ = round_msgs
    decision = NS(outcome='no_winner', winner=0, clients=['alice', 'bob'],
                  reason='every score is below min_expressiveness 3')
    text, _ = round_report(1, acks, capture, results, captured, decision)
    assert text.split('\n')[-1] == ('  decision: no_winner: every score is '
                                    'below min_expressiveness 3')


def test_winner_beyond_the_client_list_is_reported_not_raised(round_msgs):
    # A forged Decision killed round_monitor with an IndexError (issue 11).
    acks, capture, results, captured, _ = round_msgs
    decision = NS(outcome='winner', winner=7, clients=['alice', 'bob'],
                  reason='forged')
    text, _ = round_report(1, acks, capture, results, captured, decision)
    assert text.split('\n')[-1] == (
        "  decision: winner participant 7 (not in its client list "
        "['alice', 'bob']): forged")
