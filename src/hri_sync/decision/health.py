"""The DM's decisions on /diagnostics, from plain values (no ROS)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from hri_sync.wire.vocabulary import NoiseSource, Outcome, ResultStatus
from hri_sync.wire.health import OK, Health, RoundTally, WARN


class DecisionTally(RoundTally):
    """The DM's decisions by outcome (an abort is WARN) and, per
    participant, its results by status and the results that never came
    ('missing').  A status that is not a ClientResult status is counted
    as 'error'."""

    def __init__(self, participants: list[str]) -> None:
        super().__init__(Outcome.ALL, {Outcome.ABORTED: WARN},
                         client_outcomes=ResultStatus.ALL + ('missing',),
                         clients=participants)
        self._reported: dict[int, set[str]] = {}  # open round -> clients

    def on_result(self, round_id: int, client_id: str, status: str) -> None:
        """A result the DM took into round ``round_id``."""
        with self._lock:
            self._reported.setdefault(round_id, set()).add(client_id)
        self.count(status if status in ResultStatus.ALL
                   else ResultStatus.ERROR,
                   [client_id])

    def on_decision(self, round_id: int, outcome: str, reason: str,
                    count_missing: bool = True) -> None:
        """The decision of ``round_id``; the participants without a
        result are counted missing unless ``count_missing`` is false (the
        CM aborted the round before its capture: nobody was asked)."""
        with self._lock:
            reported = self._reported.pop(round_id, set())
        if count_missing:
            self.count('missing', [c for c in self.clients
                                   if c not in reported])
        self.record(round_id, outcome, reason)


def noise_health(noise_rule: bool, participants: list[str],
                 sources: dict[str, str], unknown: dict[str, int],
                 uncalibrated: dict[str, int]) -> Health:
    """The noise floors the DM was given: per participant where its last
    usable result's floor came from (``sources``, NoiseSource values), and
    the counts of results whose floor was unknown or not calibrated.
    Under the noise rule (``noise_rule``) a participant whose last floor
    is not calibrated is WARN: the threshold rule decides for it."""
    values = tuple((c, sources.get(c) or ('none' if c in sources
                                          else 'no result yet'))
                   for c in participants)
    values += tuple(('%s %s' % (what, c), str(n))
                    for what, counts in (('unknown floors of', unknown),
                                         ('uncalibrated floors of',
                                          uncalibrated))
                    for c, n in sorted(counts.items()) if n)
    if not noise_rule:
        return Health(OK, 'threshold rule: noise floors not used', values)
    bad = [c for c in participants
           if sources.get(c, '') not in NoiseSource.TRUSTED]
    if bad:
        return Health(WARN, 'noise floor of %s not calibrated: the '
                      'threshold rule decides for %s'
                      % (', '.join(bad), 'them' if len(bad) > 1 else 'it'),
                      values)
    return Health(OK, 'noise rule on %s' % ', '.join(
        '%s %s' % kv for kv in values[:len(participants)]), values)
