"""The CM's rounds on /diagnostics, from plain values (no ROS)."""

from __future__ import annotations

from typing import Any

from hri_sync.control.session import DECIDED, NO_DECISION, SHUTDOWN
from hri_sync.wire.vocabulary import RoundState
from hri_sync.wire.health import ERROR, RoundTally, WARN


class ServerTally(RoundTally):
    """The CM's rounds: their state changes and how each ended.

    An abort or a shutdown mid-round is WARN, a round captured without a
    decision ERROR (the DM did not answer); per client of ``clients``,
    NACKs ('refused') and missing ACKs.  The events are those of the
    CM's ``control.session.ControlSession``: its status updates and its
    round ends.
    """

    def __init__(self, clients: list[str] | tuple[()] = ()) -> None:
        super().__init__(
            (RoundState.SYNCING, RoundState.CAPTURING, DECIDED,
             RoundState.ABORTED, NO_DECISION, SHUTDOWN),
            {RoundState.ABORTED: WARN, NO_DECISION: ERROR, SHUTDOWN: WARN},
            client_outcomes=('refused', 'missing'), clients=clients)

    def on_status(self, round_id: int, state: str, reason: str,
                  refused: list[Any], missing: list[Any]) -> None:
        """A round's state change ('syncing', 'capturing' or 'aborted', as
        on /round_status); once the ACKs are in, count who refused or is
        missing."""
        self.record(round_id, state, reason)
        if state != RoundState.SYNCING:
            self.count('refused', refused)
            self.count('missing', missing)

    def on_end(self, round_id: int, outcome: str, message: str) -> None:
        """How a round ended: 'decided', 'aborted', 'no_decision' or
        'shutdown' (an abort its status update announced is not counted
        twice)."""
        last = self.last
        if outcome == RoundState.ABORTED and last and last[:2] == (
                round_id, RoundState.ABORTED):
            return
        self.record(round_id, outcome, message)
