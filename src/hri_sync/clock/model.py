"""Clock model: NTP offset estimation and a drift-corrected global clock.

Pure Python, no ROS.  Times are float seconds of the four clocks: ``local``
is the process's own, possibly faked system clock (what ``time.time()``
reads in a node; here always passed in), ``global`` the time server's
clock.  A model maps local to global time and bounds its own error.
"""
import math
from dataclasses import dataclass
from typing import Callable, Dict, Iterable, List

from hri_sync.wire.times import (GlobalTime, LocalTime, Seconds,
                                 fits_ros_time)
from hri_sync.wire.vocabulary import DRIFT_BOUND

MAX_DRIFT = 0.01       # |d offset / d local| of any usable model (1 %)


@dataclass(frozen=True)
class NtpSample:
    """One NTP exchange: t1 sent (local), t2 received (server), t3 sent
    (server), t4 received (local)."""

    t1: float
    t2: float
    t3: float
    t4: float

    @property
    def offset(self) -> Seconds:
        """Global minus local, assuming symmetric paths."""
        return ((self.t2 - self.t1) + (self.t3 - self.t4)) / 2.0

    @property
    def delay(self) -> Seconds:
        """Round-trip network delay, excluding the server's hold time."""
        return (self.t4 - self.t1) - (self.t3 - self.t2)

    @property
    def local_mid(self) -> LocalTime:
        """Local time the offset refers to (middle of the exchange)."""
        return LocalTime((self.t1 + self.t4) / 2.0)


@dataclass(frozen=True)
class OffsetMeasurement:
    """The best exchange of a burst, NTP-style."""

    local: LocalTime    # local time the offset refers to
    offset: Seconds     # global minus local, s
    delay: Seconds      # round trip of the chosen exchange, s
    exchanges: int      # answered exchanges in the burst

    @property
    def uncertainty(self) -> Seconds:
        """Error bound of the offset: half the round trip (path asymmetry)."""
        return self.delay / 2.0


def best_offset(samples: Iterable[NtpSample]) -> OffsetMeasurement:
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
    """A linear map from local to global time, with an error bound.

    ``global(local) = local + offset + drift * (local - local_ref)``;
    ``uncertainty`` bounds the error of ``offset`` at ``local_ref`` and
    grows by ``drift_bound`` s per s away from it (the fitted drift's own
    error and the clock's wander).  A CPM publishes one as
    hri_sync/ClockState for the other nodes of its host.  The default
    model is the identity with an infinite uncertainty: not ``ready``.
    """

    def __init__(self, local_ref: float = 0.0, offset: Seconds = 0.0,
                 drift: float = 0.0, uncertainty: Seconds = math.inf,
                 drift_bound: float = 0.0) -> None:
        self.local_ref = local_ref
        self.offset = offset
        self.drift = drift
        self.uncertainty = uncertainty
        self.drift_bound = drift_bound

    @classmethod
    def from_state(cls, local_ref: float, offset: Seconds, drift: float,
                   uncertainty: Seconds) -> 'ClockModel':
        """A model from the fields of a ClockState, validated.

        Raises ValueError naming the field when a value is not finite,
        ``uncertainty`` is negative, ``|drift|`` exceeds MAX_DRIFT (1 %,
        ten times any crystal's) or ``local_ref`` or its global time lies
        outside [0, 2**32) s (what a ROS time can carry).
        """
        return cls(local_ref, offset, drift, uncertainty).validate()

    def validate(self) -> 'ClockModel':
        """Return self if the model is usable; else raise ValueError."""
        for name in ('local_ref', 'offset', 'drift', 'uncertainty',
                     'drift_bound'):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value,
                                                         (int, float)):
                raise ValueError('clock model %s=%r is not a number'
                                 % (name, value))
            if not math.isfinite(value):
                raise ValueError('clock model %s=%r is not finite'
                                 % (name, value))
        for name, t in (('local_ref', self.local_ref),
                        ('global time at local_ref',
                         self.local_ref + self.offset)):
            if not fits_ros_time(t, zero=True):
                raise ValueError('clock model %s=%r s is outside [0, 2**32)'
                                 % (name, t))
        if self.uncertainty < 0:
            raise ValueError('clock model uncertainty=%r is negative'
                             % self.uncertainty)
        if self.drift_bound < 0:
            raise ValueError('clock model drift_bound=%r is negative'
                             % self.drift_bound)
        if abs(self.drift) > MAX_DRIFT:
            raise ValueError('clock model drift=%r exceeds +/-%g'
                             % (self.drift, MAX_DRIFT))
        return self

    @property
    def ready(self) -> bool:
        """True when the model has a finite error bound (a usable model)."""
        return math.isfinite(self.uncertainty)

    def offset_at(self, local: LocalTime) -> Seconds:
        """Global minus local at local time ``local``."""
        return self.offset + self.drift * (local - self.local_ref)

    def uncertainty_at(self, local: LocalTime) -> Seconds:
        """The error bound at local time ``local``: ``uncertainty`` grown
        by ``drift_bound`` for every s since (or before) ``local_ref``."""
        return self.uncertainty + self.drift_bound * abs(local
                                                         - self.local_ref)

    def to_global(self, local: LocalTime) -> GlobalTime:
        """Convert a local time to global time."""
        return GlobalTime(local + self.offset_at(local))

    def to_local(self, global_time: GlobalTime) -> LocalTime:
        """Convert a global time to local time (inverse of to_global)."""
        return LocalTime((global_time - self.offset
                          + self.drift * self.local_ref) / (1.0 + self.drift))

    def snapshot(self, local: LocalTime) -> 'ClockModel':
        """A copy whose uncertainty is the bound at ``local``, growth off:
        the model as published at that instant."""
        return ClockModel(self.local_ref, self.offset, self.drift,
                          self.uncertainty_at(local))

    def state(self) -> Dict[str, float]:
        """The model as a dict (the model fields of hri_sync/ClockState)."""
        return {'local_ref': self.local_ref, 'offset': self.offset,
                'drift': self.drift, 'uncertainty': self.uncertainty}


class GlobalClock(ClockModel):
    """A software-corrected global clock fitted to offset measurements.

    ``global(local) = local + offset + drift * (local - local_ref)``.
    The fit is a weighted least-squares line through the measurements of
    the last ``window`` seconds (weights fall with the round-trip delay);
    with one measurement, or less than ``min_span`` seconds of them, the
    drift is taken as zero.  ``local_ref`` is the last measurement's, so
    ``uncertainty_at`` grows with the time since the last good sync at
    ``drift_bound`` s/s (NTP assumes 15 ppm).  ``local_clock`` is the
    local clock (a callable) ``now`` reads.  The system clock is never
    touched.
    """

    def __init__(self, local_clock: Callable[[], LocalTime],
                 window: Seconds = 120.0, min_span: Seconds = 2.0,
                 max_drift: float = 1e-3, delay_slack: Seconds = 0.0005,
                 drift_bound: float = DRIFT_BOUND) -> None:
        super().__init__(drift_bound=drift_bound)
        if not (math.isfinite(drift_bound) and drift_bound >= 0):
            raise ValueError('drift bound must be >= 0 s/s, got %r'
                             % (drift_bound,))
        self._local_clock = local_clock
        self.window = window
        self.min_span = min_span
        self.max_drift = max_drift
        self.delay_slack = delay_slack
        self.measurements: List[OffsetMeasurement] = []

    def add(self, m: OffsetMeasurement) -> None:
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

    def now(self) -> GlobalTime:
        """The current global time."""
        return self.to_global(self._local_clock())

    def state(self) -> Dict[str, float]:
        """The model as a dict (fields of hri_sync/ClockState)."""
        return dict(super().state(), samples=len(self.measurements))
