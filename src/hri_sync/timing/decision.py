"""The decision module's rule: who was the most expressive?

No ROS.  Participant numbers count from 1 in the order of ``participants``.
``RoundCollector`` is the DM's state machine: it collects each round's
results until all are in or the round's deadline on the global clock.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass
from typing import Any

from hri_sync.timing.vocabulary import ON_MISSING, Outcome, ResultStatus

WINNER, NO_WINNER, TIE, ABORTED = Outcome.ALL
USABLE = ResultStatus.USABLE


@dataclass
class Verdict:
    """A decision, in the fields of hri_sync/Decision."""

    outcome: str
    winner: int          # participant number from 1; 0 for none
    scores: list         # per participant, NaN where no usable result
    reason: str


def decide(participants: list[str], results: dict[str, tuple[str, float]],
           min_value: float = 0.0, tie_margin: float = 0.0,
           on_missing: str = 'partial') -> Verdict:
    """Decide a round.

    ``results`` maps client_id -> (status, value).  A participant without a
    usable result (missing, late, no data, error, non-finite value) is left
    out of the comparison; ``on_missing`` is 'partial' (decide over those
    present, saying so in the reason) or 'abort'.  The largest score wins;
    ``no_winner`` when every score is below ``min_value``; ``tie`` when the
    best two are within ``tie_margin``.
    """
    if on_missing not in ON_MISSING:
        raise ValueError("~on_missing must be 'partial' or 'abort', got %r"
                         % (on_missing,))
    scores, problems = [], []
    for c in participants:
        status, value = results.get(c, ('missing', math.nan))
        if status in USABLE and math.isfinite(value):
            scores.append(float(value))
            if status != ResultStatus.OK:
                problems.append('%s result is %s' % (c, status))
        else:
            scores.append(math.nan)
            problems.append('%s has no usable result (%s)' % (c, status))
    present = [(s, i) for i, s in enumerate(scores) if math.isfinite(s)]
    note = ('; '.join(problems) + ': decided over the clients present'
            if problems else '')
    if not present:
        return Verdict(ABORTED, 0, scores, 'no usable result: '
                       + '; '.join(problems))
    if any(not math.isfinite(s) for s in scores) and on_missing == 'abort':
        return Verdict(ABORTED, 0, scores, '; '.join(problems)
                       + ' (~on_missing: abort)')
    ranked = sorted(present, reverse=True)
    best, best_i = ranked[0]
    suffix = (' [partial: %s]' % note) if note else ''
    if best < min_value:
        return Verdict(NO_WINNER, 0, scores,
                       'every score is below min_expressiveness %.4g'
                       % min_value + suffix)
    if len(ranked) > 1 and best - ranked[1][0] <= tie_margin:
        return Verdict(TIE, 0, scores, 'best two scores %.4g and %.4g are '
                       'within tie_margin %.4g' % (best, ranked[1][0],
                                                   tie_margin) + suffix)
    return Verdict(WINNER, best_i + 1, scores, '%s scored highest (%.4g)'
                   % (participants[best_i], best) + suffix)


@dataclass
class Closed:
    """A round the collector closed: its verdict and how it came about."""

    round: int
    verdict: Verdict
    window_end: float         # global
    why: str                  # 'all results', 'deadline' or 'aborted'
    timing_uncertainty: float  # worst of the usable results', NaN if none


class RoundCollector:
    """The DM's rounds: results per round until every participant answered
    or the deadline passed, then a decision.

    A round opens on its capture order with its window's end (global);
    its deadline is that end plus ``result_timeout``, on the global clock,
    whenever the order arrived.  ``due(now)`` closes the rounds past their
    deadline.  A result for a closed, unknown or future round, from an
    unknown client, or a second one from a client, is never merged:
    ``add`` says why and counts it in ``ignored``.
    """

    def __init__(self, participants: list[Any], result_timeout: float,
                 min_value: float = 0.0, tie_margin: float = 0.0,
                 on_missing: str = 'partial', remember: int = 100) -> None:
        if not participants:
            raise ValueError('no participants')
        if not (math.isfinite(result_timeout) and result_timeout > 0):
            raise ValueError('result_timeout must be > 0 s, got %r'
                             % (result_timeout,))
        decide(participants, {}, min_value, tie_margin, on_missing)
        self.participants = list(participants)
        self.result_timeout = result_timeout
        self.rule = (min_value, tie_margin, on_missing)
        # round -> (window end, {client: result})
        self.open_rounds: dict[
            int, tuple[float, dict[str, tuple[str, float, float]]]] = {}
        self.closed: dict[int, str] = {}  # round -> why, last ``remember``
        self.remember = remember
        self.ignored: Counter[str] = Counter()

    def open(self, round_id: int, window_end: float) -> bool:
        """A capture order for ``round_id`` whose window ends at global
        ``window_end``.  False (and counted) when already known."""
        if round_id in self.open_rounds or round_id in self.closed:
            self.ignored['duplicate_round'] += 1
            return False
        if not math.isfinite(window_end):
            self.ignored['bad_window'] += 1
            return False
        self.open_rounds[round_id] = (window_end, {})
        return True

    def deadline(self, round_id: int) -> float:
        """Global deadline of an open round."""
        return self.open_rounds[round_id][0] + self.result_timeout

    def add(
            self, round_id: int, client_id: str, status: str, value: float,
            timing_uncertainty: float = math.nan
            ) -> tuple[Closed | None, str]:
        """A ClientResult.  Returns (Closed or None, why ignored or '')."""
        why = ''
        if round_id in self.closed:
            why = 'closed_round'
        elif round_id not in self.open_rounds:
            why = 'no_open_round'
        elif client_id not in self.participants:
            why = 'unknown_client'
        elif client_id in self.open_rounds[round_id][1]:
            why = 'duplicate_result'
        if why:
            self.ignored[why] += 1
            return None, why
        results = self.open_rounds[round_id][1]
        results[client_id] = (status, value, timing_uncertainty)
        if all(c in results for c in self.participants):
            return self._close(round_id, 'all results'), ''
        return None, ''

    def next_deadline(self) -> float | None:
        """The earliest deadline of the open rounds (None if none)."""
        return min((self.deadline(r) for r in self.open_rounds),
                   default=None)

    def due(self, now: float) -> list[Any]:
        """Close the rounds whose deadline is past at global ``now``."""
        late = [r for r in self.open_rounds if now >= self.deadline(r)]
        return [self._close(r, 'deadline') for r in sorted(late)]

    def abort(self, round_id: int, reason: str) -> Closed | None:
        """The CM aborted ``round_id``: Closed (aborted), or None when it
        was closed already."""
        if round_id in self.closed:
            return None
        end = self.open_rounds.pop(round_id, (math.nan, {}))[0]
        self._remember(round_id, 'aborted')
        return Closed(round_id, Verdict(ABORTED, 0,
                                        [math.nan] * len(self.participants),
                                        reason), end, 'aborted', math.nan)

    def _remember(self, round_id: int, why: str) -> None:
        self.closed[round_id] = why
        while len(self.closed) > self.remember:
            del self.closed[min(self.closed)]

    def _close(self, round_id: int, why: str) -> Closed:
        end, results = self.open_rounds.pop(round_id)
        self._remember(round_id, why)
        verdict = decide(self.participants,
                         {c: r[:2] for c, r in results.items()}, *self.rule)
        bounds = [r[2] for r in results.values()
                  if r[0] in USABLE and math.isfinite(r[2])]
        return Closed(round_id, verdict, end, why,
                      max(bounds) if bounds else math.nan)
