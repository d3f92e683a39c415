"""Time mappings: a sample's source time to the global timeline.

No ROS.  Two strategies behind one contract (``TimeMapping``):
``ArrivalStamps`` (a sample's global arrival time) and
``DeviceClockMapper`` (its device stamp mapped to global by a
lower-envelope fit of device time against arrival time).  The C++ tracker
has the same map (``include/hri_sync/clock_map.h``), checked on the same
test vectors.
"""
import functools
import math
from typing import Any, Dict, Generic, Optional, TypeVar

import numpy as np

from hri_sync.clock.model import MAX_DRIFT
from hri_sync.wire.times import DeviceTime, GlobalTime, Seconds

# A mapping's source clock.
Source = TypeVar('Source', GlobalTime, DeviceTime)


class TimeMapping(Generic[Source]):
    """The contract of a time mapping: a sample's source time to global.

    ``observe(source, arrival)`` one sample (its time on the mapping's
    source clock, and its global arrival time); ``ready`` once the mapping
    can stamp; ``to_global(source)``; ``reset()`` to start over;
    ``state()`` a dict to publish or log; ``residual``, the mapping's own
    error estimate in s (added to the clock model's uncertainty).
    """

    kind = ''

    def observe(self, source: Source, arrival: GlobalTime) -> None:
        raise NotImplementedError

    @property
    def ready(self) -> bool:
        raise NotImplementedError

    def to_global(self, source: Source) -> GlobalTime:
        raise NotImplementedError

    def reset(self) -> None:
        raise NotImplementedError

    def state(self) -> Dict[str, Any]:
        raise NotImplementedError

    @property
    def residual(self) -> Seconds:
        raise NotImplementedError


class ArrivalStamps(TimeMapping[GlobalTime]):
    """Arrival stamping: a sample's source time is its global arrival.

    The identity map; its error is the sample's delivery delay (sensor to
    the DPM's callback), which no stamp on arrival can see.
    """

    kind = 'arrival'

    def __init__(self) -> None:
        self.samples = 0

    def observe(self, source: GlobalTime, arrival: GlobalTime) -> None:
        self.samples += 1

    @property
    def ready(self) -> bool:
        return True

    def to_global(self, source: GlobalTime) -> GlobalTime:
        return source

    def reset(self) -> None:
        self.samples = 0

    def state(self) -> Dict[str, Any]:
        return {'kind': self.kind, 'ready': True, 'samples': self.samples}

    @property
    def residual(self) -> Seconds:
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


class DeviceClockMapper(TimeMapping[DeviceTime]):
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

    def __init__(self, window: Seconds = 30.0, min_span: Seconds = 5.0,
                 settle: int = 5) -> None:
        self.window = window
        self.min_span = min_span
        self.settle = settle
        self.resets = 0
        self._device = np.empty(1024)
        self._delay = np.empty(1024)      # arrival - device
        self._clear()

    def _clear(self):
        self._lo = self._hi = 0
        self.offset: Optional[float] = None
        self.drift = 0.0
        self.ref = 0.0

    def observe(self, device: DeviceTime, arrival: GlobalTime) -> None:
        """Add one sample's device stamp and global arrival time, and
        refit."""
        self.add(device, arrival)
        self.refit()

    def add(self, device: DeviceTime, arrival: GlobalTime) -> None:
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

    def refit(self) -> None:
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
        # A device clock is a crystal: a slope past MAX_DRIFT is delay that
        # changed (a producer that fell behind and caught up), not drift.
        drift = _median(slopes) if len(slopes) else 0.0
        self.drift = min(MAX_DRIFT, max(-MAX_DRIFT, drift))
        base = _median(md - self.drift * mt)
        # Shift the line down onto the envelope (no point below it).
        self.offset = base + float(np.min(
            d - (base + self.drift * (t - self.ref))))

    @property
    def ready(self) -> bool:
        """Whether the fit holds enough samples to map stamps."""
        return self._hi - self._lo >= self.settle

    @property
    def samples(self) -> int:
        """Points in the fit's window."""
        return self._hi - self._lo

    @property
    def last_device(self) -> Optional[DeviceTime]:
        """The newest device stamp in the fit (None when empty)."""
        return DeviceTime(float(self._device[self._hi - 1])) \
            if self.samples else None

    def to_global(self, device: DeviceTime) -> GlobalTime:
        """Global time of a device stamp (call observe first)."""
        if self.offset is None:
            raise ValueError('no sample observed yet')
        return GlobalTime(device + self.offset
                          + self.drift * (device - self.ref))

    def reset(self) -> None:
        """Start the fit over (counted in ``resets``)."""
        self._clear()
        self.resets += 1

    @property
    def residual(self) -> Seconds:
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

    def state(self) -> Dict[str, Any]:
        return {'kind': self.kind, 'ready': self.ready,
                'offset': self.offset, 'drift': self.drift, 'ref': self.ref,
                'samples': self.samples, 'resets': self.resets,
                'residual': self.residual}
