"""Keeping a host's global clock against the time server.

No ROS, no sockets, no sleeping of its own: the measurement (an NTP burst,
``hri_sync.clock.ntp.measure``), the local clock and, for the resync
loop, ``sleep`` and ``stopped`` are injected.  ``ClockSync`` owns the
``GlobalClock`` fit, remembers why the last measurement failed and hands
out ``ClockStatus`` snapshots: what a ClockState carries and what the
CPM's ACK rule (``protocol.ClientSchedule.on_sync``) judges.  While the
time server is unreachable the model is kept (holdover) and its
uncertainty grows with the time since the last good measurement at the
clock's drift bound.
"""

from __future__ import annotations

import math
import threading
from dataclasses import dataclass
from typing import Callable, TYPE_CHECKING

from hri_sync.clock.model import DRIFT_BOUND, ClockModel, GlobalClock

if TYPE_CHECKING:
    from hri_sync.wire.times import LocalTime


class SyncError(Exception):
    """A measurement of the clock that failed; the message says why."""


@dataclass(frozen=True)
class ClockStatus:
    """A host's clock at one instant.

    ``model`` is a copy of the fit (its uncertainty grows from
    ``local_ref`` at ``drift_bound``); ``error`` is why the last
    measurement failed ('' when it succeeded); ``samples`` the
    measurements behind the fit; ``round_trip`` the NTP round trip of the
    last measurement (s; NaN when it failed or none was made).
    """

    model: ClockModel
    error: str
    samples: int
    round_trip: float = math.nan

    @property
    def ok(self) -> bool:
        """True when there is a model to use (fresh or in holdover)."""
        return self.model.ready

    def reason(self, local: LocalTime) -> str:
        """Why the clock is not fresh at local time ``local`` ('' if it is):
        the error without a model, the holdover's age and cause with one."""
        if not self.ok:
            return self.error or 'not measured yet'
        if not self.error:
            return ''
        return ('holdover: no good sync for %.1f s (%s); uncertainty '
                '%.3f ms' % (local - self.model.local_ref, self.error,
                             self.model.uncertainty_at(local) * 1e3))


class ClockSync:
    """Measures the offset to the time server into a ``GlobalClock``.

    ``measure()`` returns an ``OffsetMeasurement`` or raises SyncError
    (``ntp.NtpError`` is one), OSError or ValueError (an inconsistent
    burst): a failure is kept as ``last_error`` and the model is left as
    it was.  ``local_clock()`` is the local clock the measurements and
    the model use; ``drift_bound`` and ``fit`` are the GlobalClock's
    options.  ``sync`` and ``status`` may be called from several threads;
    ``latest`` is the status after the last measurement, read without
    waiting for one in progress (an NTP burst to a server that does not
    answer takes seconds).
    """

    def __init__(self, measure: Callable, local_clock: Callable,
                 resync_period: float = 5.0, first_pause: float = 0.5,
                 drift_bound: float = DRIFT_BOUND, **fit) -> None:
        if not (math.isfinite(resync_period) and resync_period > 0):
            raise ValueError('resync period must be > 0 s, got %r'
                             % (resync_period,))
        if not (math.isfinite(first_pause) and first_pause > 0):
            raise ValueError('first pause must be > 0 s, got %r'
                             % (first_pause,))
        self._measure = measure
        self.local_clock = local_clock
        self.resync_period = resync_period
        self.first_pause = first_pause
        self.clock = GlobalClock(local_clock, drift_bound=drift_bound, **fit)
        self.last_error = 'not measured yet'
        self._lock = threading.Lock()
        self.latest = self._status()

    def sync(self) -> ClockStatus:
        """Make one measurement into the model; return the new status."""
        with self._lock:
            try:
                m = self._measure()
            except (SyncError, OSError, ValueError) as e:
                self.last_error = str(e) or type(e).__name__
            else:
                self.clock.add(m)
                self.last_error = ''
            self.latest = self._status()
            return self.latest

    def status(self) -> ClockStatus:
        """The current ClockStatus (no measurement)."""
        with self._lock:
            return self._status()

    def _status(self) -> ClockStatus:
        c = self.clock
        return ClockStatus(
            ClockModel(c.local_ref, c.offset, c.drift, c.uncertainty,
                       c.drift_bound),
            self.last_error, len(c.measurements),
            c.measurements[-1].delay if c.measurements
            and not self.last_error else math.nan)

    def run(
            self, sleep: Callable, stopped: Callable,
            report: Callable) -> None:
        """The resync loop: measure, ``report(status)``, ``sleep(s)``;
        until ``stopped()``.

        The pauses are 0.5, 1, 2, 4 s (from ``first_pause``, doubling) up
        to ``resync_period``, so the drift is known within seconds of the
        start instead of one resync period.
        """
        pause = self.first_pause
        while not stopped():
            report(self.sync())
            if stopped():
                return
            pause = min(pause, self.resync_period)
            sleep(pause)
            pause *= 2
