"""The DPM's results on /diagnostics, from plain values (no ROS)."""

from __future__ import annotations

from typing import TYPE_CHECKING

from hri_sync.wire.vocabulary import ResultStatus
from hri_sync.wire.health import ERROR, OK, Health, RoundTally, WARN, text


def result_tally() -> RoundTally:
    """A DPM's results by ClientResult status: partial and no_data are
    WARN, error ERROR, while they are the last round's."""
    return RoundTally(ResultStatus.ALL, {
        ResultStatus.PARTIAL: WARN, ResultStatus.NO_DATA: WARN,
        ResultStatus.LATE: WARN, ResultStatus.ERROR: ERROR})


def noise_health(has_baseline: bool, level: float, start: float,
                 failed: str, quiet: float) -> Health:
    """A DPM's noise floor: calibrated (``level``, the score of the
    calibration window that began at global ``start``), or not (WARN for
    a processor with a quiet baseline: its floor is the quietest second
    seen, ``quiet``, which the decision module does not trust);
    ``failed``: why the last calibration window did not calibrate."""
    values: tuple[tuple[str, str], ...] = (
        ('calibration', text(level, '%.4g')),
        ('calibrated at (global)', text(start, '%.3f')),
        ('quiet baseline', text(quiet, '%.4g')))
    if failed:
        values += (('last calibration failed', failed),)
    if level == level:      # not NaN: calibrated
        return Health(OK, 'calibrated: noise level %.4g' % level, values)
    if not has_baseline:
        return Health(OK, 'the processor measures no quiet level: its '
                      'own noise estimate, if any', values)
    return Health(WARN, 'not calibrated%s: the floor is the quietest '
                  'second seen (%s), not trusted by the decision module'
                  % (' (%s)' % failed if failed else '',
                     text(quiet, '%.4g')), values)
