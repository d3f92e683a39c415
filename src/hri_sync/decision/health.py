"""The DM's decisions on /diagnostics, from plain values (no ROS)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from hri_sync.wire.vocabulary import Outcome, ResultStatus
from hri_sync.wire.health import RoundTally, WARN


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
