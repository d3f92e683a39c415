"""hri_sync.decision.rule: the decision module's rule."""

import math

import pytest

from hri_sync.decision.rule import (ABORTED, NO_WINNER, TIE, WINNER,
                                    RoundCollector, Verdict, decide)

P = ['left', 'right']


def same(verdict, expected):
    """Compare Verdicts with NaN scores equal to NaN."""
    assert (verdict.outcome, verdict.winner, verdict.reason) == (
        expected.outcome, expected.winner, expected.reason)
    assert len(verdict.scores) == len(expected.scores)
    for a, b in zip(verdict.scores, expected.scores):
        assert (math.isnan(a) and math.isnan(b)) or a == b


def test_largest_score_wins_numbered_from_one():
    v = decide(P, {'left': ('ok', 2.0), 'right': ('ok', 5.5)})
    assert v == Verdict(WINNER, 2, [2.0, 5.5], 'right scored highest (5.5)')
    v = decide(P, {'left': ('ok', 6.0), 'right': ('ok', 5.5)})
    assert (v.outcome, v.winner) == (WINNER, 1)


def test_no_winner_when_every_score_is_below_the_minimum():
    v = decide(P, {'left': ('ok', 0.5), 'right': ('ok', 0.25)},
               min_value=1.0)
    assert v == Verdict(NO_WINNER, 0, [0.5, 0.25],
                        'every score is below min_expressiveness 1')


def test_a_score_equal_to_the_minimum_can_win():
    v = decide(P, {'left': ('ok', 1.0), 'right': ('ok', 0.25)},
               min_value=1.0)
    assert (v.outcome, v.winner) == (WINNER, 1)


def test_exact_tie():
    v = decide(P, {'left': ('ok', 3.0), 'right': ('ok', 3.0)})
    assert v == Verdict(TIE, 0, [3.0, 3.0], 'best two scores 3 and 3 are '
                        'within tie_margin 0')


def test_tie_within_margin_and_winner_outside_it():
    results = {'left': ('ok', 3.0), 'right': ('ok', 3.25)}
    assert decide(P, results, tie_margin=0.25).outcome == TIE
    v = decide(P, results, tie_margin=0.125)
    assert (v.outcome, v.winner) == (WINNER, 2)


def test_tie_only_between_the_best_two():
    v = decide(['a', 'b', 'c'], {'a': ('ok', 1.0), 'b': ('ok', 4.0),
                                 'c': ('ok', 4.0)})
    assert v.outcome == TIE
    v = decide(['a', 'b', 'c'], {'a': ('ok', 1.0), 'b': ('ok', 1.0),
                                 'c': ('ok', 4.0)})
    assert (v.outcome, v.winner) == (WINNER, 3)


def test_nobody_answered_aborts():
    same(decide(P, {}), Verdict(
        ABORTED, 0, [math.nan, math.nan],
        'no usable result: left has no usable result (missing); right has '
        'no usable result (missing)'))


def test_partial_decides_over_those_present_and_says_so():
    v = decide(P, {'left': ('ok', 3.0), 'right': ('late', 9.0)})
    same(v, Verdict(WINNER, 1, [3.0, math.nan],
                    'left scored highest (3) [partial: right has no usable '
                    'result (late): decided over the clients present]'))


def test_abort_on_missing():
    v = decide(P, {'left': ('ok', 3.0)}, on_missing='abort')
    same(v, Verdict(ABORTED, 0, [3.0, math.nan],
                    'right has no usable result (missing) '
                    '(~on_missing: abort)'))


@pytest.mark.parametrize('value', [math.nan, math.inf, -math.inf])
def test_non_finite_value_is_not_usable(value):
    v = decide(P, {'left': ('ok', value), 'right': ('ok', 1.0)})
    assert (v.outcome, v.winner) == (WINNER, 2)
    assert math.isnan(v.scores[0])
    assert 'left has no usable result (ok)' in v.reason


def test_partial_status_is_usable_but_noted():
    v = decide(P, {'left': ('partial', 4.0), 'right': ('ok', 1.0)})
    assert (v.outcome, v.winner, v.scores) == (WINNER, 1, [4.0, 1.0])
    assert v.reason.endswith('[partial: left result is partial: decided '
                             'over the clients present]')


def test_no_data_and_error_statuses_are_not_usable():
    v = decide(P, {'left': ('no_data', 0.0), 'right': ('error', 7.0)})
    assert v.outcome == ABORTED
    assert v.reason == ('no usable result: left has no usable result '
                        '(no_data); right has no usable result (error)')


def test_no_winner_with_a_missing_client_is_partial():
    v = decide(P, {'left': ('ok', 0.1)}, min_value=1.0)
    assert v.outcome == NO_WINNER
    assert '[partial: right has no usable result (missing)' in v.reason


def test_bad_on_missing_raises():
    with pytest.raises(ValueError, match="~on_missing must be 'partial' or "
                       "'abort', got 'skip'"):
        decide(P, {}, on_missing='skip')


# -- RoundCollector: the DM's rounds on a fake global clock ------------------

def collector(timeout=2.0, **kw):
    return RoundCollector(P, timeout, **kw)


def test_round_decided_when_every_participant_answered():
    c = collector()
    assert c.open(1, 1000.0)
    assert c.add(1, 'left', 'ok', 2.0, 1e-4) == (None, '')
    closed, why = c.add(1, 'right', 'ok', 5.5, 3e-4)
    assert why == '' and closed.why == 'all results'
    assert (closed.verdict.outcome, closed.verdict.winner) == (WINNER, 2)
    assert closed.window_end == 1000.0
    assert closed.timing_uncertainty == 3e-4      # the worst participant
    assert c.due(5000.0) == []


def test_deadline_is_the_window_end_plus_the_timeout_in_global_time():
    # However late the capture order reached the DM, the deadline stays
    # the window's end + result_timeout.
    c = collector(timeout=0.5)
    c.open(4, 1000.0)
    c.add(4, 'left', 'ok', 3.0, 1e-4)
    assert c.deadline(4) == 1000.5 and c.next_deadline() == 1000.5
    assert c.due(1000.499) == []
    (closed,) = c.due(1000.5)
    assert closed.why == 'deadline' and closed.verdict.winner == 1
    assert 'right has no usable result (missing)' in closed.verdict.reason


def test_a_result_after_the_deadline_is_counted_not_merged():
    c = collector(timeout=0.5)
    c.open(4, 1000.0)
    c.add(4, 'left', 'ok', 3.0)
    c.due(1000.6)
    assert c.add(4, 'right', 'ok', 9.0) == (None, 'closed_round')
    assert c.ignored['closed_round'] == 1
    assert c.due(2000.0) == []


def test_unknown_future_duplicate_are_ignored_and_counted():
    c = collector()
    c.open(1, 1000.0)
    assert c.add(2, 'left', 'ok', 1.0) == (None, 'no_open_round')
    assert c.add(1, 'mallory', 'ok', 1.0) == (None, 'unknown_client')
    c.add(1, 'left', 'ok', 1.0)
    assert c.add(1, 'left', 'ok', 99.0) == (None, 'duplicate_result')
    assert not c.open(1, 1000.0)
    assert c.ignored == {'no_open_round': 1, 'unknown_client': 1,
                         'duplicate_result': 1, 'duplicate_round': 1}
    closed, _ = c.add(1, 'right', 'ok', 0.5)
    assert closed.verdict.scores == [1.0, 0.5]


def test_an_order_with_another_window_reopens_a_closed_round_once():
    """A forged capture order decided at its deadline does not take the
    round from the CM's own order with another window."""
    c = collector(timeout=0.5)
    assert c.open(3, 500.0)                  # forged
    assert c.due(501.0)[0].why == 'deadline'
    assert not c.open(3, 500.0)              # the same again: duplicate
    assert c.open(3, 1000.0)                 # the CM's own
    assert not c.open(3, 2000.0)             # open with another window
    assert c.ignored == {'duplicate_round': 1, 'conflicting_round': 2}
    c.add(3, 'left', 'ok', 2.0)
    closed, _ = c.add(3, 'right', 'ok', 1.0)
    assert closed.verdict.scores == [2.0, 1.0] and closed.window_end == 1000.0


def test_worst_bound_counts_only_usable_results():
    c = collector()
    c.open(1, 1000.0)
    c.add(1, 'left', 'ok', 2.0, 2e-4)
    closed, _ = c.add(1, 'right', 'no_data', math.nan, 9e-3)
    assert closed.timing_uncertainty == 2e-4
    c.open(2, 1010.0)
    c.add(2, 'left', 'late', math.nan, math.nan)
    (closed,) = c.due(1013.0)
    assert closed.verdict.outcome == ABORTED
    assert math.isnan(closed.timing_uncertainty)


def test_abort_closes_once():
    c = collector()
    c.open(3, 1000.0)
    closed = c.abort(3, 'round 3 aborted: no ACK from right')
    assert closed.verdict.outcome == ABORTED and closed.why == 'aborted'
    assert closed.verdict.reason == 'round 3 aborted: no ACK from right'
    assert c.abort(3, 'again') is None
    assert c.add(3, 'left', 'ok', 1.0) == (None, 'closed_round')
    # A round aborted before its capture order (at the ACKs) too.
    closed = c.abort(4, 'round 4 aborted: no ACK from left')
    assert closed.verdict.outcome == ABORTED
    assert math.isnan(closed.window_end)


def test_collector_remembers_a_bounded_number_of_rounds():
    c = collector(remember=3)
    for n in range(1, 8):
        c.open(n, 1000.0 + n)
        c.due(2000.0)
    assert sorted(c.closed) == [5, 6, 7]


def test_collector_refuses_bad_parameters():
    with pytest.raises(ValueError, match='result_timeout'):
        RoundCollector(P, 0.0)
    with pytest.raises(ValueError, match='on_missing'):
        RoundCollector(P, 1.0, on_missing='skip')
    with pytest.raises(ValueError, match='no participants'):
        RoundCollector([], 1.0)


def test_a_lone_participant_is_not_said_to_score_highest():
    v = decide(['eeg'], {'eeg': ('ok', 1281.0)})
    assert (v.outcome, v.winner) == (WINNER, 1)
    assert v.reason == 'eeg is the only participant (1281): nothing to compare'
