"""The CPM's rounds on /diagnostics, from plain values (no ROS)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from hri_sync.wire.vocabulary import ResultStatus
from hri_sync.wire.health import RoundTally, WARN


def client_tally() -> RoundTally:
    """A CPM's rounds: its answers to sync_time and its capture orders.

    A NACK or a late capture order leaves the status at WARN until the
    next round (the clock's own status says ERROR while it cannot sync).
    """
    return RoundTally(('acked', 'nacked', 'scheduled', ResultStatus.LATE),
                      {'nacked': WARN, ResultStatus.LATE: WARN})
