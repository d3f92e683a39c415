"""Clock model: NTP offset estimation and a drift-corrected global clock.

Pure Python, no ROS.  Times are float seconds.  ``local`` is the host's
own clock (``time.time()``); ``global`` is the time server's clock.
"""
import math
import time
from dataclasses import dataclass


@dataclass(frozen=True)
class NtpSample:
    """One NTP exchange: t1 sent (local), t2 received (server), t3 sent
    (server), t4 received (local)."""

    t1: float
    t2: float
    t3: float
    t4: float

    @property
    def offset(self):
        """Global minus local, assuming symmetric paths."""
        return ((self.t2 - self.t1) + (self.t3 - self.t4)) / 2.0

    @property
    def delay(self):
        """Round-trip network delay, excluding the server's hold time."""
        return (self.t4 - self.t1) - (self.t3 - self.t2)

    @property
    def local_mid(self):
        """Local time the offset refers to (middle of the exchange)."""
        return (self.t1 + self.t4) / 2.0


@dataclass(frozen=True)
class OffsetMeasurement:
    """The best exchange of a burst, NTP-style."""

    local: float        # local time the offset refers to
    offset: float       # global minus local, s
    delay: float        # round trip of the chosen exchange, s
    exchanges: int      # answered exchanges in the burst

    @property
    def uncertainty(self):
        """Error bound of the offset: half the round trip (path asymmetry)."""
        return self.delay / 2.0


def best_offset(samples):
    """Return the minimum-delay sample of a burst as an OffsetMeasurement.

    Raises ValueError for an empty burst or a sample with negative delay.
    """
    samples = list(samples)
    if not samples:
        raise ValueError('no NTP sample answered')
    for s in samples:
        stamps = (s.t1, s.t2, s.t3, s.t4)
        if s.delay < 0 or not all(map(math.isfinite, stamps)):
            raise ValueError('inconsistent NTP sample %r (delay %.6f s)'
                             % (s, s.delay))
    best = min(samples, key=lambda s: s.delay)
    return OffsetMeasurement(best.local_mid, best.offset, best.delay,
                             len(samples))


class ClockModel:
    """A linear map from local to global time.

    ``global(local) = local + offset + drift * (local - local_ref)``; a CPM
    publishes one as hri_sync/ClockState for the other nodes of its host.
    """

    def __init__(self, local_ref=0.0, offset=0.0, drift=0.0,
                 uncertainty=math.inf):
        self.local_ref = local_ref
        self.offset = offset
        self.drift = drift
        self.uncertainty = uncertainty

    def offset_at(self, local):
        """Global minus local at local time ``local``."""
        return self.offset + self.drift * (local - self.local_ref)

    def to_global(self, local):
        """Convert a local time to global time."""
        return local + self.offset_at(local)

    def to_local(self, global_time):
        """Convert a global time to local time (inverse of to_global)."""
        return ((global_time - self.offset + self.drift * self.local_ref)
                / (1.0 + self.drift))


class GlobalClock(ClockModel):
    """A software-corrected global clock fitted to offset measurements.

    ``global(local) = local + offset + drift * (local - local_ref)``.
    The fit is a weighted least-squares line through the measurements of
    the last ``window`` seconds (weights fall with the round-trip delay);
    with one measurement, or less than ``min_span`` seconds of them, the
    drift is taken as zero.  The system clock is never touched.
    """

    def __init__(self, local_clock=time.time, window=120.0, min_span=2.0,
                 max_drift=1e-3, delay_slack=0.0005):
        super().__init__()
        self._local_clock = local_clock
        self.window = window
        self.min_span = min_span
        self.max_drift = max_drift
        self.delay_slack = delay_slack
        self.measurements = []

    @property
    def synced(self):
        """True once at least one measurement was added."""
        return bool(self.measurements)

    def add(self, m):
        """Add an OffsetMeasurement and refit the model."""
        self.measurements.append(m)
        horizon = m.local - self.window
        self.measurements = [x for x in self.measurements
                             if x.local >= horizon]
        self._fit()

    def _fit(self):
        ms = self.measurements
        last = ms[-1]
        self.local_ref = last.local
        if len(ms) < 2 or ms[-1].local - ms[0].local < self.min_span:
            best = min(ms, key=lambda x: x.delay)
            self.offset = best.offset
            self.drift = 0.0
            self.uncertainty = best.uncertainty
            return
        weights = [1.0 / max(x.delay, 1e-6) ** 2 for x in ms]
        sw = sum(weights)
        mx = sum(w * (x.local - last.local) for w, x in zip(weights, ms)) / sw
        my = sum(w * x.offset for w, x in zip(weights, ms)) / sw
        sxx = sum(w * (x.local - last.local - mx) ** 2
                  for w, x in zip(weights, ms))
        sxy = sum(w * (x.local - last.local - mx) * (x.offset - my)
                  for w, x in zip(weights, ms))
        drift = sxy / sxx if sxx > 0 else 0.0
        drift = max(-self.max_drift, min(self.max_drift, drift))
        self.drift = drift
        self.offset = my - drift * mx
        # The residual spread counts only bursts whose round trip was near
        # the best one (NTP's clock filter): one burst caught in a queue
        # must not inflate the uncertainty for the whole window.
        best = min(x.delay for x in ms)
        near = [x for x in ms if x.delay <= 2 * best + self.delay_slack]
        residuals = [abs(x.offset - self.offset_at(x.local)) for x in near]
        self.uncertainty = best / 2.0 + max(residuals)

    def now(self):
        """The current global time."""
        return self.to_global(self._local_clock())

    def state(self):
        """The model as a dict (fields of hri_sync/ClockState)."""
        return {'local_ref': self.local_ref, 'offset': self.offset,
                'drift': self.drift, 'uncertainty': self.uncertainty,
                'samples': len(self.measurements)}
