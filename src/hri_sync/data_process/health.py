"""The DPM's results on /diagnostics, from plain values (no ROS)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from hri_sync.wire.vocabulary import ResultStatus
from hri_sync.wire.health import ERROR, RoundTally, WARN


def result_tally() -> RoundTally:
    """A DPM's results by ClientResult status: partial and no_data are
    WARN, error ERROR, while they are the last round's."""
    return RoundTally(ResultStatus.ALL, {
        ResultStatus.PARTIAL: WARN, ResultStatus.NO_DATA: WARN,
        ResultStatus.LATE: WARN, ResultStatus.ERROR: ERROR})
