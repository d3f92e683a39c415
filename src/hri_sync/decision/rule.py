"""The decision module's rule: who was the most expressive?

No ROS.  Participant numbers count from 1 in the order of ``participants``.
``RoundCollector`` is the DM's state machine: it collects each round's
results until all are in or the round's deadline on the global clock.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field
from typing import Any

from hri_sync.data_process.noise_floor import valid_floor
from hri_sync.wire.rounds import RoundWindows
from hri_sync.wire.vocabulary import (ON_MISSING, NoiseSource, Outcome,
                                      ResultStatus)

WINNER, NO_WINNER, TIE, ABORTED = Outcome.ALL
USABLE = ResultStatus.USABLE
# ~decision_rule: 'noise' (each score against its client's noise floor)
# or 'threshold' (every score against the fixed min_expressiveness).
NOISE, THRESHOLD = RULES = ('noise', 'threshold')
DEFAULT_NOISE_FACTOR = 3.0


@dataclass
class Verdict:
    """A decision, in the fields of hri_sync/Decision."""

    outcome: str
    winner: int          # participant number from 1; 0 for none
    scores: list         # per participant, NaN where no usable result
    reason: str
    # per participant, NaN where unknown (or no usable result); not
    # compared (== compares what the Decision says)
    noise_floors: list | None = field(default=None, compare=False)


def decide(participants: list[str], results: dict[str, tuple],
           min_value: float = 0.0, tie_margin: float = 0.0,
           on_missing: str = 'partial', rule: str = THRESHOLD,
           noise_factor: float = DEFAULT_NOISE_FACTOR) -> Verdict:
    """Decide a round.

    ``results`` maps client_id -> (status, value), (status, value,
    noise_floor) or (status, value, noise_floor, noise_source).  A
    participant without a usable result (missing, late,
    no data, error, non-finite value) is left out of the comparison;
    ``on_missing`` is 'partial' (decide over those present, saying so in
    the reason) or 'abort'.  The largest score wins, unless:

    - ``rule`` 'threshold': ``no_winner`` when every score is below
      ``min_value``; ``tie`` when the best two are within ``tie_margin``;
    - ``rule`` 'noise': ``no_winner`` ("within noise") when the best score
      is not above ``noise_factor`` x its client's noise floor, or not
      above the runner-up by more than their combined noise, the square
      root of the sum of the two noise floors squared; then ``tie`` when
      the best two are within ``tie_margin``.  A noise floor that is not
      a finite number >= 0 is unknown, and one whose ``noise_source`` is
      not trusted (``NoiseSource.TRUSTED``: a floor no calibration window
      measured) is not taken: that comparison falls back to the
      threshold rule's (``min_value``, ``tie_margin``), said in the
      reason.
    """
    if on_missing not in ON_MISSING:
        raise ValueError("~on_missing must be 'partial' or 'abort', got %r"
                         % (on_missing,))
    if rule not in RULES:
        raise ValueError('~decision_rule must be %s, got %r'
                         % (' or '.join(RULES), rule))
    if not (math.isfinite(noise_factor) and noise_factor >= 0):
        raise ValueError('~noise_factor must be >= 0, got %r'
                         % (noise_factor,))
    scores, floors, problems, untrusted = _taken(participants, results)
    present = [(s, i) for i, s in enumerate(scores) if math.isfinite(s)]
    note = ('; '.join(problems) + ': decided over the clients present'
            if problems else '')
    if not present:
        return Verdict(ABORTED, 0, scores, 'no usable result: '
                       + '; '.join(problems), floors)
    if any(not math.isfinite(s) for s in scores) and on_missing == 'abort':
        return Verdict(ABORTED, 0, scores, '; '.join(problems)
                       + ' (~on_missing: abort)', floors)
    ranked = sorted(present, reverse=True)
    best, best_i = ranked[0]
    suffix = (' [partial: %s]' % note) if note else ''

    def verdict(outcome: str, winner: int, reason: str) -> Verdict:
        return Verdict(outcome, winner, scores, reason + suffix, floors)

    said: list[str] = []    # what the noise rule checked, for a winner
    if rule == NOISE:
        within, said = _noise_rule(participants, ranked, floors, min_value,
                                   noise_factor, untrusted)
        if within:
            return verdict(NO_WINNER, 0, within)
    elif best < min_value:
        return verdict(NO_WINNER, 0, 'every score is below '
                       'min_expressiveness %.4g' % min_value)
    if len(ranked) > 1 and best - ranked[1][0] <= tie_margin:
        return verdict(TIE, 0, 'best two scores %.4g and %.4g are within '
                       'tie_margin %.4g' % (best, ranked[1][0], tie_margin))
    return verdict(WINNER, best_i + 1,
                   _winner_reason(participants, best_i, best, said))


def _taken(participants: list[str], results: dict[str, tuple]
           ) -> tuple[list[float], list[float], list[str], set[str]]:
    """``decide``'s scores and noise floors per participant (NaN: no
    usable result, or a floor unknown or not trusted), the problems with
    the results, and the participants whose floor was given but not
    calibrated."""
    scores, floors, problems = [], [], []
    untrusted: set[str] = set()
    for c in participants:
        status, value, *rest = results.get(c, ('missing', math.nan))
        floor = rest[0] if rest and valid_floor(rest[0]) else math.nan
        if len(rest) > 1 and rest[1] not in NoiseSource.TRUSTED and \
                math.isfinite(floor):
            untrusted.add(c)
            floor = math.nan
        if status in USABLE and math.isfinite(value):
            scores.append(float(value))
            floors.append(float(floor))
            if status != ResultStatus.OK:
                problems.append('%s result is %s' % (c, status))
        else:
            scores.append(math.nan)
            floors.append(math.nan)
            problems.append('%s has no usable result (%s)' % (c, status))
    return scores, floors, problems, untrusted


def _winner_reason(participants: list[str], best_i: int, best: float,
                   said: list[str]) -> str:
    """Why participant ``best_i`` wins (alone: nothing compared)."""
    if len(participants) == 1:
        return '%s is the only participant (%.4g): nothing to compare%s' % (
            participants[0], best, '; ' + '; '.join(said) if said else '')
    return '%s scored highest (%.4g)%s' % (
        participants[best_i], best, ': ' + '; '.join(said) if said else '')


def _unknown(name: str, untrusted: set[str]) -> str:
    """Why the noise floor of ``name`` is not taken."""
    return 'noise floor of %s %s' % (
        name, 'not calibrated' if name in untrusted else 'unknown')


def _noise_rule(participants: list[str], ranked: list[tuple[float, int]],
                floors: list[float], min_value: float,
                noise_factor: float,
                untrusted: set[str]) -> tuple[str, list[str]]:
    """The noise rule on scores ``ranked`` (best first): (the reason of a
    ``no_winner``, or '' and what was checked); ``untrusted``: the
    participants whose floor was given but not calibrated."""
    best, best_i = ranked[0]
    name, floor = participants[best_i], floors[best_i]
    said = []
    if not math.isfinite(floor):
        said.append('%s: min_expressiveness rule'
                    % _unknown(name, untrusted))
        if best < min_value:
            return ('%s; every score is below min_expressiveness %.4g'
                    % (said[0], min_value)), said
    elif not best > noise_factor * floor:
        return ('within noise: best score %.4g (%s) is not above %g x its '
                'noise floor %.4g' % (best, name, noise_factor, floor)), said
    else:
        said.append('%.3gx its noise floor %.4g' % (best / floor, floor)
                    if floor > 0 else 'above its noise floor 0')
    if len(ranked) > 1:
        second, second_i = ranked[1]
        other = floors[second_i]
        if math.isfinite(floor) and math.isfinite(other):
            combined = math.hypot(floor, other)
            if not best - second > combined:
                return ('within noise: best two scores %.4g (%s) and %.4g '
                        '(%s) differ by %.4g, not more than their combined '
                        'noise %.4g (noise floors %.4g, %.4g)'
                        % (best, name, second, participants[second_i],
                           best - second, combined, floor, other)), said
            said.append('%.4g above the runner-up, combined noise %.4g'
                        % (best - second, combined))
        elif math.isfinite(floor):
            said.append('%s: tie_margin rule'
                        % _unknown(participants[second_i], untrusted))
    return '', said


def calibration_verdict(participants: list[str],
                        results: dict[str, tuple]) -> Verdict:
    """The calibration window's "decision": never a winner (nobody
    moves); the reason gives each participant's still score and the noise
    floor its DPM calibrated, or why it did not.  ``results`` as
    ``decide``'s."""
    scores, floors, parts = [], [], []
    for c in participants:
        status, value, *rest = results.get(c, ('missing', math.nan))
        floor = rest[0] if rest and valid_floor(rest[0]) else math.nan
        source = rest[1] if len(rest) > 1 else ''
        ok = status == ResultStatus.OK and math.isfinite(value)
        scores.append(float(value) if ok else math.nan)
        floors.append(float(floor) if ok else math.nan)
        if not ok:
            parts.append('%s not calibrated (%s)' % (c, status))
        else:
            parts.append('%s still score %.4g, noise floor %.4g (%s)'
                         % (c, value, floor, source or 'no source'))
    return Verdict(NO_WINNER, 0, scores, 'calibration window, nobody '
                   'moving: no winner; ' + '; '.join(parts), floors)


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
    ``add`` says why and counts it in ``ignored``.  With ``calibration``
    it collects the calibration window (round 0, ``CALIBRATION_ROUND``),
    closed by ``calibration_verdict``.
    """

    def __init__(self, participants: list[Any], result_timeout: float,
                 min_value: float = 0.0, tie_margin: float = 0.0,
                 on_missing: str = 'partial', remember: int = 100,
                 rule: str = THRESHOLD,
                 noise_factor: float = DEFAULT_NOISE_FACTOR,
                 calibration: bool = False) -> None:
        if not participants:
            raise ValueError('no participants')
        if not (math.isfinite(result_timeout) and result_timeout > 0):
            raise ValueError('result_timeout must be > 0 s, got %r'
                             % (result_timeout,))
        decide(participants, {}, min_value, tie_margin, on_missing, rule,
               noise_factor)
        self.participants = list(participants)
        self.result_timeout = result_timeout
        self.rule = (min_value, tie_margin, on_missing, rule, noise_factor)
        self.calibration = calibration
        # round -> (window end, {client: (status, value, timing
        # uncertainty, noise floor, noise source)})
        self.open_rounds: dict[int, tuple[float, dict[str, tuple]]] = {}
        # results whose noise floor was not a finite number >= 0 (NaN:
        # unknown, e.g. a processor without one; negative or infinite:
        # invalid), and those whose floor no calibration measured
        self.noise_unknown: Counter[str] = Counter()
        self.noise_uncalibrated: Counter[str] = Counter()
        self.noise_sources: dict[str, str] = {}   # client -> the last
        # the rounds closed, the last ``remember``
        self.closed: set[int] = set()
        self.remember = remember
        self.rounds = RoundWindows(remember)  # every window each round had
        self.ignored: Counter[str] = Counter()

    def open(self, round_id: int, window_end: float) -> bool:
        """A capture order for ``round_id`` whose window ends at global
        ``window_end``.  False (and counted) when already known.

        A second order of a round follows ``wire.rounds``, as the DPM's
        commands do: the same window end is ignored ('duplicate_round');
        another one is ignored while the round is open and opens it again
        once it is closed (the CM orders a round once: the earlier order
        was a forged one under its caller id, decided at its deadline),
        both counted as 'conflicting_round'.
        """
        if not math.isfinite(window_end):
            self.ignored['bad_window'] += 1
            return False
        repeat, take = self.rounds.take(round_id, (window_end,),
                                        round_id in self.open_rounds)
        if repeat:
            self.ignored[repeat + '_round'] += 1
        if not take:
            return False
        self.closed.discard(round_id)
        self.open_rounds[round_id] = (window_end, {})
        return True

    def deadline(self, round_id: int) -> float:
        """Global deadline of an open round."""
        return self.open_rounds[round_id][0] + self.result_timeout

    def add(
            self, round_id: int, client_id: str, status: str, value: float,
            timing_uncertainty: float = math.nan,
            noise_floor: float = math.nan, noise_source: str = ''
            ) -> tuple[Closed | None, str]:
        """A ClientResult.  Returns (Closed or None, why ignored or '').
        A ``noise_floor`` that is not a finite number >= 0 is taken as
        unknown and counted in ``noise_unknown`` (by client), one whose
        ``noise_source`` says no calibration measured it in
        ``noise_uncalibrated``."""
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
        if status in USABLE and not valid_floor(noise_floor):
            self.noise_unknown[client_id] += 1
            noise_floor = math.nan
        elif status in USABLE and noise_source not in NoiseSource.TRUSTED:
            self.noise_uncalibrated[client_id] += 1
        if status in USABLE:
            self.noise_sources[client_id] = noise_source
        results[client_id] = (status, value, timing_uncertainty, noise_floor,
                              noise_source)
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
        if round_id not in self.open_rounds:     # aborted before its order
            self.rounds.note(round_id, (math.nan,))
        end = self.open_rounds.pop(round_id, (math.nan, {}))[0]
        self._remember(round_id)
        nans = [math.nan] * len(self.participants)
        return Closed(round_id, Verdict(ABORTED, 0, nans, reason, nans),
                      end, 'aborted', math.nan)

    def _remember(self, round_id: int) -> None:
        self.closed.add(round_id)
        while len(self.closed) > self.remember:
            self.closed.remove(min(self.closed))

    def _close(self, round_id: int, why: str) -> Closed:
        end, results = self.open_rounds.pop(round_id)
        self._remember(round_id)
        taken: dict[str, tuple] = {c: (r[0], r[1], r[3], r[4])
                                   for c, r in results.items()}
        verdict = calibration_verdict(self.participants, taken) \
            if self.calibration else \
            decide(self.participants, taken, *self.rule[:3],
                   rule=self.rule[3], noise_factor=self.rule[4])
        bounds = [r[2] for r in results.values()
                  if r[0] in USABLE and math.isfinite(r[2])]
        return Closed(round_id, verdict, end, why,
                      max(bounds) if bounds else math.nan)
