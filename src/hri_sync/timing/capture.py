"""The DPM's capture window, defined on the global timeline.

No ROS.  Samples are stamped in global time before they reach the window;
the window keeps exactly those with ``start <= stamp < end``, whenever
the process happened to wake up.
"""
import math
import statistics
from collections import deque

from hri_sync.timing.processors import Frame


class SampleBuffer:
    """A short history of stamped samples, so arming late loses nothing.

    Keeps samples of the last ``keep`` seconds (by stamp), and all samples
    after a held window start.
    """

    def __init__(self, keep=5.0):
        self.keep = keep
        self._frames = deque()
        self._holds = []

    def hold(self, start):
        """Keep every sample stamped from ``start`` on until released."""
        self._holds.append(start)

    def release(self, start):
        """Drop the hold placed for ``start``."""
        self._holds.remove(start)

    def add(self, stamp, msg):
        """Store one sample with its global stamp."""
        self._frames.append(Frame(stamp, msg))
        horizon = min([stamp - self.keep] + self._holds)
        while self._frames and self._frames[0].stamp < horizon:
            self._frames.popleft()

    def take(self, start, end):
        """The samples stamped in [start, end), in stamp order."""
        return sorted((f for f in self._frames if start <= f.stamp < end),
                      key=lambda f: f.stamp)


def window_stats(stamps, start, end, max_gap=None):
    """Coverage, dropped frames and first-frame offset of a window.

    ``stamps`` are the kept samples' global stamps (sorted).  The nominal
    period is their median spacing; a gap longer than ``max_gap`` (default
    2.5 periods) is uncovered, and each missing period in a gap counts as a
    dropped frame; a lone sample has no period, so covers nothing.  Returns
    a dict: coverage (0..1), dropped, period, first_frame_offset (NaN
    without samples).
    """
    dur = end - start
    if not stamps:
        return {'coverage': 0.0, 'dropped': 0, 'period': math.nan,
                'first_frame_offset': math.nan}
    gaps = [b - a for a, b in zip(stamps, stamps[1:])]
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


class DeviceClockMapper:
    """Maps a sensor's own timestamps to global time.

    Each sample gives ``arrival - device`` (global arrival minus device
    stamp) = true offset + transport delay >= true offset.  The offset is
    the lower envelope of those values, fitted with drift over a sliding
    window: the minimum-delay idea of NTP, applied to one-way samples.  A
    device clock that goes back (a restarted sensor) starts the fit over
    and is counted in ``resets``.  Until a fit holds ``settle`` samples it
    is not ``ready``: alone, a sample that arrived late (a reader that
    stalled) would set the offset that late.
    """

    def __init__(self, window=30.0, min_span=5.0, settle=5):
        self.window = window
        self.min_span = min_span
        self.settle = settle
        self._points = deque()   # (device, arrival - device)
        self.offset = None
        self.drift = 0.0
        self.ref = 0.0
        self.resets = 0

    def observe(self, device, arrival):
        """Add one sample's device stamp and global arrival time."""
        if self._points and device < self._points[-1][0]:
            self._points.clear()
            self.resets += 1
        self._points.append((device, arrival - device))
        while self._points and self._points[0][0] < device - self.window:
            self._points.popleft()
        self._fit()

    def _fit(self):
        pts = list(self._points)
        self.ref = pts[-1][0]
        span = pts[-1][0] - pts[0][0]
        if span < self.min_span:
            self.offset = min(d for _, d in pts)
            self.drift = 0.0
            return
        # Lower envelope: the minimum of each bin (about 1 s wide, at least
        # 4 bins), then the Theil-Sen line through the minima: the median of
        # their pairwise slopes, so a bin holding only late samples (a
        # sensor or reader that stalled) cannot tilt it.
        bins = min(30, max(4, int(span)))
        mins = {}
        for t, d in pts:
            k = min(bins - 1, int((t - pts[0][0]) / span * bins))
            if k not in mins or d < mins[k][1]:
                mins[k] = (t - self.ref, d)
        mins = list(mins.values())
        if len(mins) < 2:
            self.offset = min(d for _, d in pts)
            self.drift = 0.0
            return
        slopes = [(b[1] - a[1]) / (b[0] - a[0])
                  for i, a in enumerate(mins) for b in mins[i + 1:]
                  if b[0] != a[0]]
        self.drift = statistics.median(slopes) if slopes else 0.0
        base = statistics.median(d - self.drift * t for t, d in mins)
        # Shift the line down onto the envelope (no point below it).
        self.offset = base + min(d - (base + self.drift * (t - self.ref))
                                 for t, d in pts)

    @property
    def ready(self):
        """Whether the fit holds enough samples to map stamps."""
        return len(self._points) >= self.settle

    def to_global(self, device):
        """Global time of a device stamp (call observe first)."""
        if self.offset is None:
            raise ValueError('no sample observed yet')
        return device + self.offset + self.drift * (device - self.ref)
