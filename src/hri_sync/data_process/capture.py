"""The DPM's capture window, on the global timeline.

No ROS.  A sample is stamped in global time by a time mapping
(``hri_sync.data_process.mapping``) before it reaches a window.  A
``CaptureWindow`` keeps exactly
the samples with ``start <= stamp < end``, whenever the process happened
to wake up, feeds them to its processor as they arrive and knows when it
is complete.
"""
import heapq
import math
from array import array
from collections import Counter, deque
from typing import Any, Deque, Dict, List, Optional, Sequence, Tuple

from hri_sync.data_process.processors import (Frame, ProcessResult, Processor,
                                              WindowRun)
from hri_sync.wire.times import GlobalTime, Seconds
from hri_sync.wire.vocabulary import MIN_COVERAGE, ResultStatus

OK, PARTIAL, NO_DATA, ERROR = (ResultStatus.OK, ResultStatus.PARTIAL,
                               ResultStatus.NO_DATA, ResultStatus.ERROR)
# A gap between samples longer than this many periods is uncovered.
GAP_PERIODS = 2.5


class SampleBuffer:
    """A short history of stamped samples, so arming late loses nothing.

    Keeps the samples of the last ``keep`` seconds (by stamp).
    """

    def __init__(self, keep: Seconds = 2.0) -> None:
        self.keep = keep
        self._frames: Deque[Frame] = deque()

    def add(self, stamp: GlobalTime, msg: Any) -> None:
        """Store one sample with its global stamp."""
        self._frames.append(Frame(stamp, msg))
        while self._frames and self._frames[0].stamp < stamp - self.keep:
            self._frames.popleft()

    def take(self, start: GlobalTime, end: GlobalTime) -> List[Frame]:
        """The samples stamped in [start, end), in stamp order."""
        return sorted((f for f in self._frames if start <= f.stamp < end),
                      key=lambda f: f.stamp)


def window_stats(stamps: Sequence[float], start: GlobalTime,
                 end: GlobalTime, max_gap: Optional[Seconds] = None,
                 max_period: Seconds = math.nan) -> Dict[str, Any]:
    """Coverage, dropped frames and first-frame offset of a window.

    ``stamps`` are the kept samples' global stamps (sorted).  The period
    is the median of their positive spacings (a repeated stamp is no
    period), at most ``max_period`` when that is given: otherwise a sensor
    that delivered a few samples evenly all window (a tracker starved of
    CPU) covers it.  A gap longer than ``max_gap`` (default GAP_PERIODS
    periods) is uncovered, and each missing period in a gap counts as a
    dropped frame; without ``max_period`` a lone sample has no period, so
    covers nothing.  Returns a dict: coverage (0..1), dropped, period,
    first_frame_offset (NaN without samples).
    """
    dur = end - start
    if not stamps:
        return {'coverage': 0.0, 'dropped': 0, 'period': math.nan,
                'first_frame_offset': math.nan}
    gaps = [b - a for a, b in zip(stamps, stamps[1:]) if b > a]
    period = sorted(gaps)[len(gaps) // 2] if gaps else math.nan
    if max_period > 0 and not period <= max_period:
        period = max_period
    if max_gap is None:
        max_gap = GAP_PERIODS * period if math.isfinite(period) else 0.0
    covered = sum(g for g in gaps if g <= max_gap)
    dropped = (sum(max(0, round(g / period) - 1) for g in gaps)
               if math.isfinite(period) else 0)
    # The edges: start -> first sample and last sample -> end.
    lead, tail = stamps[0] - start, end - stamps[-1]
    covered += sum(e for e in (lead, tail) if e <= max_gap)
    return {'coverage': max(0.0, min(1.0, covered / dur)) if dur > 0 else 0.0,
            'dropped': int(dropped), 'period': period,
            'first_frame_offset': stamps[0] - start}


def window_status(used: int, coverage: float, min_coverage: float,
                  failed: bool = False) -> str:
    """The status rule of a ClientResult: error when processing failed,
    no_data when no sample in the window was usable (``used``: how many
    the processor used), partial when the data covered less than
    ``min_coverage`` of it, else ok."""
    if failed:
        return ERROR
    if not used:
        return NO_DATA
    return PARTIAL if coverage < min_coverage else OK


class CaptureWindow:
    """One capture window [start, end) (global s), fed as samples arrive.

    ``offer`` each stamped sample: one stamped in the window goes to the
    processor (in stamp order: samples wait up to ``reorder`` s of stamps
    for a stamp-earlier one still on its way); the window is complete
    (``complete``) when a sample stamped at or after its end arrives, when
    one stamped in it comes less than ``least_gap`` (the least spacing of
    the sensor's recent stamps, given to ``offer``) before its end, so
    that the next is due after the end (``completed_by`` ``last``: a
    result one frame sooner), or (``due``) when the sensor's observed
    period plus ``margin`` has passed its end, on the global clock, with
    nothing more.  A sample stamped
    before its start that arrives after its end, or a window sample that
    comes too late for stamp order, is counted in ``late``, never added.
    Its coverage is judged at a period of at most ``max_period``
    (``window_stats``).
    """

    def __init__(self, round_id: int, start: GlobalTime, end: GlobalTime,
                 processor: Processor, reorder: Seconds = 0.2,
                 margin: Seconds = 0.03,
                 max_period: Seconds = math.nan) -> None:
        if not (math.isfinite(start) and math.isfinite(end) and end > start):
            raise ValueError('capture window [%r, %r) is empty or not '
                             'finite' % (start, end))
        self.round = round_id
        self.start, self.end = start, end
        self.reorder = reorder
        self.margin = margin
        self.max_period = max_period
        self.complete = False
        self.completed_by = ''
        self.late = 0
        self.rejected: Counter = Counter()  # refused at stamping, by reason
        self.bound = 0.0           # worst stamp error bound of its samples
        self.stamps = array('d')   # in-window stamps, arrival order
        self.wake_lateness = math.nan
        self._run = WindowRun(processor, start, end)
        # heap of (stamp, seq, msg)
        self._waiting: List[Tuple[float, int, Any]] = []
        self._seq = 0
        self._fed = -math.inf      # stamp of the last sample processed
        self._newest = -math.inf   # newest stamp offered

    def offer(self, stamp: GlobalTime, msg: Any, arrival: GlobalTime,
              bound: Seconds = 0.0, least_gap: Seconds = math.nan) -> bool:
        """Offer a sample stamped ``stamp`` that arrived at global time
        ``arrival`` with stamp error bound ``bound``; ``least_gap``: the
        least spacing of the sensor's recent stamps (NaN: unknown).
        Returns True when it is in the window (and so is to be
        republished as captured)."""
        if self.complete:
            if stamp < self.end:
                self.late += 1
            return False
        self._newest = max(self._newest, stamp)
        if stamp >= self.end:
            self.complete = True
            self.completed_by = 'sample'
            return False
        if stamp < self.start:
            if arrival >= self.end:
                self.late += 1
            return False
        if stamp < self._fed:
            self.late += 1
            return False
        heapq.heappush(self._waiting, (stamp, self._seq, msg))
        self._seq += 1
        self.stamps.append(stamp)
        self.bound = max(self.bound, bound)
        while self._waiting and \
                self._waiting[0][0] < self._newest - self.reorder:
            self._feed()
        if stamp + least_gap > self.end:    # False for NaN
            self.complete = True
            self.completed_by = 'last'
        return True

    def _feed(self):
        stamp, _, msg = heapq.heappop(self._waiting)
        self._fed = stamp
        self._run.add(Frame(stamp, msg))

    def due(self, now: GlobalTime, period: Seconds,
            lag: Seconds = 0.0) -> bool:
        """Whether, at global time ``now``, the window is complete for
        lack of samples: its end and the next sample expected after the
        newest one (``period`` s later; NaN when unknown) are ``margin``
        plus ``lag`` s past (``lag``: how late after their stamps samples
        have been arriving).  Marks it complete when so."""
        if self.complete:
            return True
        expected: float = self.end
        if math.isfinite(period) and math.isfinite(self._newest):
            expected = max(expected, self._newest + period)
        if now >= expected + self.margin + lag:
            self.complete = True
            self.completed_by = 'timeout'
        return self.complete

    def finish(self, min_coverage: float = MIN_COVERAGE) -> Tuple[
            str, Optional[ProcessResult], Dict[str, Any], str]:
        """Process the remaining samples; returns (status, ProcessResult
        or None, window_stats dict, error text)."""
        while self._waiting:
            self._feed()
        stats = window_stats(sorted(self.stamps), self.start, self.end,
                             max_period=self.max_period)
        try:
            result, error = self._run.result(), ''
        except Exception as e:  # a processor bug must not kill the client
            result, error = None, repr(e)
        if result is not None and math.isfinite(result.coverage):
            # The processor knows its stream's sample clock (bunched
            # stamps of a stream delivered in bursts lost nothing).
            stats = dict(stats, coverage=result.coverage,
                         dropped=result.frames_dropped or 0)
        status = window_status(result.frames_used if result else 0,
                               stats['coverage'], min_coverage,
                               failed=result is None)
        return status, result, stats, error
