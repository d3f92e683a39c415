"""The DPM's capture window and time mapping, on the global timeline.

No ROS.  A sample is stamped in global time by a time mapping before it
reaches a window: ``ArrivalStamps`` (its global arrival time) or
``DeviceClockMapper`` (its device stamp mapped to global), two strategies
behind one contract (``TimeMapping``).  A ``CaptureWindow`` keeps exactly
the samples with ``start <= stamp < end``, whenever the process happened
to wake up, feeds them to its processor as they arrive and knows when it
is complete.
"""
import functools
import heapq
import math
from array import array
from collections import Counter, deque

import numpy as np

from hri_sync.timing.processors import Frame, WindowRun
from hri_sync.timing.vocabulary import MIN_COVERAGE, ResultStatus

OK, PARTIAL, NO_DATA, ERROR = (ResultStatus.OK, ResultStatus.PARTIAL,
                               ResultStatus.NO_DATA, ResultStatus.ERROR)


class SampleBuffer:
    """A short history of stamped samples, so arming late loses nothing.

    Keeps the samples of the last ``keep`` seconds (by stamp).
    """

    def __init__(self, keep=2.0):
        self.keep = keep
        self._frames = deque()

    def add(self, stamp, msg):
        """Store one sample with its global stamp."""
        self._frames.append(Frame(stamp, msg))
        while self._frames and self._frames[0].stamp < stamp - self.keep:
            self._frames.popleft()

    def take(self, start, end):
        """The samples stamped in [start, end), in stamp order."""
        return sorted((f for f in self._frames if start <= f.stamp < end),
                      key=lambda f: f.stamp)


def window_stats(stamps, start, end, max_gap=None):
    """Coverage, dropped frames and first-frame offset of a window.

    ``stamps`` are the kept samples' global stamps (sorted).  The nominal
    period is the median of their positive spacings (a repeated stamp is
    no period); a gap longer than ``max_gap`` (default 2.5 periods) is
    uncovered, and each missing period in a gap counts as a dropped frame;
    a lone sample has no period, so covers nothing.  Returns a dict:
    coverage (0..1), dropped, period, first_frame_offset (NaN without
    samples).
    """
    dur = end - start
    if not stamps:
        return {'coverage': 0.0, 'dropped': 0, 'period': math.nan,
                'first_frame_offset': math.nan}
    gaps = [b - a for a, b in zip(stamps, stamps[1:]) if b > a]
    period = sorted(gaps)[len(gaps) // 2] if gaps else math.nan
    if max_gap is None:
        max_gap = 2.5 * period if gaps else 0.0
    covered = sum(g for g in gaps if g <= max_gap)
    dropped = sum(max(0, round(g / period) - 1) for g in gaps) if gaps else 0
    # The edges: start -> first sample and last sample -> end.
    lead, tail = stamps[0] - start, end - stamps[-1]
    covered += sum(e for e in (lead, tail) if e <= max_gap)
    return {'coverage': max(0.0, min(1.0, covered / dur)) if dur > 0 else 0.0,
            'dropped': int(dropped), 'period': period,
            'first_frame_offset': stamps[0] - start}


def window_status(used, coverage, min_coverage, failed=False):
    """The status rule of a ClientResult: error when processing failed,
    no_data when no sample in the window was usable (``used``: how many
    the processor used), partial when the data covered less than
    ``min_coverage`` of it, else ok."""
    if failed:
        return ERROR
    if not used:
        return NO_DATA
    return PARTIAL if coverage < min_coverage else OK


class TimeMapping:
    """The contract of a time mapping: a sample's source time to global.

    ``observe(source, arrival)`` one sample (its time on the mapping's
    source clock, and its global arrival time); ``ready`` once the mapping
    can stamp; ``to_global(source)``; ``reset()`` to start over;
    ``state()`` a dict to publish or log; ``residual``, the mapping's own
    error estimate in s (added to the clock model's uncertainty).
    """

    kind = ''

    def observe(self, source, arrival):
        raise NotImplementedError

    @property
    def ready(self):
        raise NotImplementedError

    def to_global(self, source):
        raise NotImplementedError

    def reset(self):
        raise NotImplementedError

    def state(self):
        raise NotImplementedError

    @property
    def residual(self):
        raise NotImplementedError


class ArrivalStamps(TimeMapping):
    """Arrival stamping: a sample's source time is its global arrival.

    The identity map; its error is the sample's delivery delay (sensor to
    the DPM's callback), which no stamp on arrival can see.
    """

    kind = 'arrival'

    def __init__(self):
        self.samples = 0

    def observe(self, source, arrival):
        self.samples += 1

    @property
    def ready(self):
        return True

    def to_global(self, source):
        return source

    def reset(self):
        self.samples = 0

    def state(self):
        return {'kind': self.kind, 'ready': True, 'samples': self.samples}

    @property
    def residual(self):
        return 0.0


def _median(a):
    """statistics.median of a float array ((a + b) / 2 of the middle two
    for an even count), by partition."""
    n = len(a)
    k = n // 2
    if n % 2:
        return float(np.partition(a, k)[k])
    p = np.partition(a, (k - 1, k))
    return float((p[k - 1] + p[k]) / 2)


@functools.lru_cache(maxsize=None)
def _pairs(n):
    """Index arrays (i, j) of the pairs i < j of n points."""
    return np.triu_indices(n, 1)


class DeviceClockMapper(TimeMapping):
    """Maps a sensor's own timestamps to global time.

    Each sample gives ``arrival - device`` (global arrival minus device
    stamp) = true offset + transport delay >= true offset.  The offset is
    the lower envelope of those values, fitted with drift over a sliding
    window: the minimum-delay idea of NTP, applied to one-way samples.  A
    device clock that goes back (a restarted sensor) starts the fit over
    and is counted in ``resets``.  Until a fit holds ``settle`` samples it
    is not ``ready``: alone, a sample that arrived late (a reader that
    stalled) would set the offset that late.  The fit is vectorized, so a
    1 kHz stream with 30,000 points in its window stays cheap.
    """

    kind = 'device'

    def __init__(self, window=30.0, min_span=5.0, settle=5):
        self.window = window
        self.min_span = min_span
        self.settle = settle
        self.resets = 0
        self._device = np.empty(1024)
        self._delay = np.empty(1024)      # arrival - device
        self._clear()

    def _clear(self):
        self._lo = self._hi = 0
        self.offset = None
        self.drift = 0.0
        self.ref = 0.0

    def observe(self, device, arrival):
        """Add one sample's device stamp and global arrival time, and
        refit."""
        self.add(device, arrival)
        self.refit()

    def add(self, device, arrival):
        """Add one sample without refitting: ``to_global`` keeps the last
        fit until ``refit`` (the fit costs O(points in the window))."""
        if not (math.isfinite(device) and math.isfinite(arrival)):
            raise ValueError('device stamp %r / arrival %r: not finite'
                             % (device, arrival))
        if self._hi > self._lo and device < self._device[self._hi - 1]:
            self._clear()
            self.resets += 1
        self._append(device, arrival - device)
        t = self._device[self._lo:self._hi]
        self._lo += int(np.searchsorted(t, device - self.window, 'left'))

    def refit(self):
        """Fit the map to the samples in the window."""
        self._fit()

    def _append(self, device, delay):
        if self._hi == len(self._device):
            n = self._hi - self._lo
            size = len(self._device) * (2 if n > len(self._device) // 2
                                        else 1)
            for name in ('_device', '_delay'):
                old = getattr(self, name)
                new = np.empty(size)
                new[:n] = old[self._lo:self._hi]
                setattr(self, name, new)
            self._lo, self._hi = 0, n
        self._device[self._hi] = device
        self._delay[self._hi] = delay
        self._hi += 1

    def _points(self):
        return self._device[self._lo:self._hi], self._delay[self._lo:self._hi]

    def _bin_minima(self, t, d, span):
        """Index of each bin's least-delayed point (first one of equals),
        bins about 1 s wide, at least 4, over ``span``."""
        bins = min(30, max(4, int(span)))
        k = ((t - t[0]) / span * bins).astype(np.int64)
        np.minimum(k, bins - 1, out=k)
        starts = np.searchsorted(k, np.arange(bins), 'left')
        starts = starts[np.append(starts[1:] > starts[:-1],
                                  starts[-1] < len(k))]
        mins = np.full(bins, np.inf)
        mins[k[starts]] = np.minimum.reduceat(d, starts)
        at_min = np.flatnonzero(d == mins[k])
        return at_min[np.searchsorted(at_min, starts, 'left')]

    def _fit(self):
        t, d = self._points()
        self.ref = float(t[-1])
        span = float(t[-1] - t[0])
        if span < self.min_span:
            self.offset = float(d.min())
            self.drift = 0.0
            return
        # Lower envelope: the minimum of each bin (about 1 s wide, at least
        # 4 bins), then the Theil-Sen line through the minima: the median of
        # their pairwise slopes, so a bin holding only late samples (a
        # sensor or reader that stalled) cannot tilt it.
        idx = self._bin_minima(t, d, span)
        mt, md = t[idx] - self.ref, d[idx]
        if len(idx) < 2:
            self.offset = float(d.min())
            self.drift = 0.0
            return
        i, j = _pairs(len(idx))
        dt = mt[j] - mt[i]
        keep = dt != 0
        slopes = (md[j] - md[i])[keep] / dt[keep]
        self.drift = _median(slopes) if len(slopes) else 0.0
        base = _median(md - self.drift * mt)
        # Shift the line down onto the envelope (no point below it).
        self.offset = base + float(np.min(
            d - (base + self.drift * (t - self.ref))))

    @property
    def ready(self):
        """Whether the fit holds enough samples to map stamps."""
        return self._hi - self._lo >= self.settle

    @property
    def samples(self):
        """Points in the fit's window."""
        return self._hi - self._lo

    @property
    def last_device(self):
        """The newest device stamp in the fit (None when empty)."""
        return float(self._device[self._hi - 1]) if self.samples else None

    def to_global(self, device):
        """Global time of a device stamp (call observe first)."""
        if self.offset is None:
            raise ValueError('no sample observed yet')
        return device + self.offset + self.drift * (device - self.ref)

    def reset(self):
        """Start the fit over (counted in ``resets``)."""
        self._clear()
        self.resets += 1

    @property
    def residual(self):
        """The median height of each ~1 s bin's least-delayed sample above
        the fitted line (s): the scatter of the envelope the map follows;
        a bin of stalled samples, which the line ignores, does not count.
        0 with fewer than two points."""
        t, d = self._points()
        if len(t) < 2 or self.offset is None:
            return 0.0
        span = float(t[-1] - t[0])
        idx = self._bin_minima(t, d, span) if span > 0 else np.arange(len(t))
        line = self.offset + self.drift * (t[idx] - self.ref)
        return max(0.0, _median(d[idx] - line))

    def state(self):
        return {'kind': self.kind, 'ready': self.ready,
                'offset': self.offset, 'drift': self.drift, 'ref': self.ref,
                'samples': self.samples, 'resets': self.resets,
                'residual': self.residual}


class CaptureWindow:
    """One capture window [start, end) (global s), fed as samples arrive.

    ``offer`` each stamped sample: one stamped in the window goes to the
    processor (in stamp order: samples wait up to ``reorder`` s of stamps
    for a stamp-earlier one still on its way); the window is complete
    (``complete``) when a sample stamped at or after its end arrives, or
    (``due``) when the sensor's observed period plus ``margin`` has passed
    its end, on the global clock, with nothing more.  A sample stamped
    before its start that arrives after its end, or a window sample that
    comes too late for stamp order, is counted in ``late``, never added.
    """

    def __init__(self, round_id, start, end, processor, reorder=0.2,
                 margin=0.03):
        if not (math.isfinite(start) and math.isfinite(end) and end > start):
            raise ValueError('capture window [%r, %r) is empty or not '
                             'finite' % (start, end))
        self.round = round_id
        self.start, self.end = start, end
        self.reorder = reorder
        self.margin = margin
        self.complete = False
        self.completed_by = ''
        self.late = 0
        self.rejected = Counter()  # samples refused at stamping, by reason
        self.bound = 0.0           # worst stamp error bound of its samples
        self.stamps = array('d')   # in-window stamps, arrival order
        self.wake_lateness = math.nan
        self._run = WindowRun(processor, start, end)
        self._waiting = []         # heap of (stamp, seq, msg)
        self._seq = 0
        self._fed = -math.inf      # stamp of the last sample processed
        self._newest = -math.inf   # newest stamp offered

    def offer(self, stamp, msg, arrival, bound=0.0):
        """Offer a sample stamped ``stamp`` that arrived at global time
        ``arrival`` with stamp error bound ``bound``.  Returns True when it
        is in the window (and so is to be republished as captured)."""
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
        return True

    def _feed(self):
        stamp, _, msg = heapq.heappop(self._waiting)
        self._fed = stamp
        self._run.add(Frame(stamp, msg))

    def due(self, now, period, lag=0.0):
        """Whether, at global time ``now``, the window is complete for
        lack of samples: its end and the next sample expected after the
        newest one (``period`` s later; NaN when unknown) are ``margin``
        plus ``lag`` s past (``lag``: how late after their stamps samples
        have been arriving).  Marks it complete when so."""
        if self.complete:
            return True
        expected = self.end
        if math.isfinite(period) and math.isfinite(self._newest):
            expected = max(expected, self._newest + period)
        if now >= expected + self.margin + lag:
            self.complete = True
            self.completed_by = 'timeout'
        return self.complete

    def finish(self, min_coverage=MIN_COVERAGE):
        """Process the remaining samples; returns (status, ProcessResult
        or None, window_stats dict, error text)."""
        while self._waiting:
            self._feed()
        stats = window_stats(sorted(self.stamps), self.start, self.end)
        try:
            result, error = self._run.result(), ''
        except Exception as e:  # a processor bug must not kill the client
            result, error = None, repr(e)
        status = window_status(result.frames_used if result else 0,
                               stats['coverage'], min_coverage,
                               failed=result is None)
        return status, result, stats, error
