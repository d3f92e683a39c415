"""hri_sync.timing.decision: the decision module's rule."""

import math

import pytest

from hri_sync.timing.decision import (ABORTED, NO_WINNER, TIE, WINNER, Verdict,
                                      decide)

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
