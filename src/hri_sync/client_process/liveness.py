"""Is a client's DPM alive, and is its sensor delivering?

No ROS.  The DPM publishes a heartbeat (``hri_sync/DpmState``) every
``~heartbeat_period`` s: how many samples its sensor topic delivered and
how long ago the last one arrived.  The CPM feeds each heartbeat to a
``Liveness`` with its own local arrival time and, on each sync_time,
asks ``verdict(now)``: the CPM ACKs only when it is alive.  All times
are the CPM's local clock (the DPM runs on the same host); durations
measured by the DPM (the sample's age) are added to the heartbeat's
arrival, so the two processes' clocks need not agree.  When the sensor's
driver reports its own state (a tracker's status: "not tracking:
searching: no person-sized object in view", "cannot open ..."), a
silent sensor's reason says what the driver last said, so a NACK names
the cause.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Callable

from hri_sync.wire.health import ERROR, LEVEL_NAMES, OK, Health, text

MAX_STATUS = 300    # characters of a driver's status message kept
DRIVER_LEVELS = {**LEVEL_NAMES, 3: 'STALE'}   # DiagnosticStatus levels


@dataclass
class Beat:
    """One DPM heartbeat, as the CPM received it."""

    received: float     # local arrival time at the CPM, s
    input: str          # the sensor topic the DPM reads
    samples: int        # samples received since the DPM started
    sample_age: float   # s from the last sample to the beat (NaN: none)
    rate: float         # observed sample rate, Hz (NaN: unknown)
    refused: int = 0    # samples the DPM refused (not of its type, ...)
    refused_reason: str = ''    # why it refused the last one


@dataclass
class Verdict:
    """Whether the CPM may ACK, and why not."""

    ok: bool
    reason: str = ''


class Liveness:
    """The DPM/sensor liveness rule of one CPM.

    The DPM is alive when its last heartbeat arrived at most
    ``dpm_timeout`` s ago; its sensor when its last sample is at most
    ``sensor_timeout`` s old (the age the heartbeat reports plus the
    time since the heartbeat).  ``sensor_timeout`` None: the DPM has no
    sensor to watch.  ``started`` is the CPM's local start, for the
    reason given before any heartbeat.  ``listening`` (None: not
    checked) says whether the DPM takes this CPM's capture orders: a
    DPM's heartbeat reaches a CPM that has just started (respawned)
    before the DPM has connected to its orders, and an order sent then
    is lost.
    """

    def __init__(self, dpm_timeout: float, sensor_timeout: float | None,
                 started: float,
                 listening: Callable[[], bool] | None = None) -> None:
        if not (isinstance(dpm_timeout, (int, float))
                and math.isfinite(dpm_timeout) and dpm_timeout > 0):
            raise ValueError('~dpm_timeout must be > 0 s, got %r'
                             % (dpm_timeout,))
        if sensor_timeout is not None and not (
                isinstance(sensor_timeout, (int, float))
                and math.isfinite(sensor_timeout) and sensor_timeout > 0):
            raise ValueError('~sensor_timeout must be > 0 s (or unset: no '
                             'sensor), got %r' % (sensor_timeout,))
        self.dpm_timeout = float(dpm_timeout)
        self.sensor_timeout = sensor_timeout
        self.started = started
        self.listening = listening
        self.last: Beat | None = None
        self.driver: tuple[float, int, str] | None = None
        self.driver_rejected = 0

    def on_driver_status(self, received: float, level: object,
                         message: object) -> bool:
        """The sensor driver's own status (a /diagnostics level and
        message) as received at local time ``received``; one that is not
        a diagnostic level and a message is rejected and counted
        (returns False)."""
        if not (isinstance(level, int) and level in DRIVER_LEVELS
                and isinstance(message, str)):
            self.driver_rejected += 1
            return False
        self.driver = (received, level, ' '.join(message.split())[
            :MAX_STATUS])
        return True

    def _silent(self, now: float, why: str) -> Verdict:
        """A silent sensor's Verdict: ``why``, and what its driver last
        said."""
        if self.driver is None:
            return Verdict(False, why)
        received, level, message = self.driver
        return Verdict(False, '%s; its driver said %.1f s ago: %s %s'
                       % (why, now - received, DRIVER_LEVELS[level],
                          message))

    def on_beat(self, beat: Beat) -> bool:
        """Record a heartbeat (a ``Beat``); an older one than the last is
        ignored (returns False)."""
        if self.last is not None and beat.received < self.last.received:
            return False
        self.last = beat
        return True

    def verdict(self, now: float) -> Verdict:
        """The ``Verdict`` at local time ``now``."""
        beat = self.last
        if beat is None:
            return Verdict(False, 'dpm not alive: no dpm_state from the DPM '
                           'in the %.1f s since this CPM started'
                           % (now - self.started))
        silence = now - beat.received
        if silence > self.dpm_timeout:
            return Verdict(False, 'dpm not alive: no dpm_state for %.1f s '
                           '(~dpm_timeout %.1f s)'
                           % (silence, self.dpm_timeout))
        if self.listening is not None and not self.listening():
            return Verdict(False, 'dpm not listening: it sends dpm_state '
                           'but takes no capture orders from this CPM yet '
                           '(its capture_command not connected)')
        if self.sensor_timeout is None:
            return Verdict(True)
        if beat.samples == 0 and beat.refused:
            return Verdict(False, 'sensor %s delivers samples the DPM '
                           'refuses (%d so far; the last: %s)'
                           % (beat.input, beat.refused,
                              beat.refused_reason or 'no reason given'))
        if beat.samples == 0 or not math.isfinite(beat.sample_age):
            return self._silent(now, 'sensor %s silent: the DPM has '
                                'received no sample from it' % beat.input)
        age = beat.sample_age + silence
        if age > self.sensor_timeout:
            return self._silent(now, 'sensor %s silent: last sample %.1f s '
                                'ago (~sensor_timeout %.1f s)'
                                % (beat.input, age, self.sensor_timeout))
        return Verdict(True)

    def health(self, now: float) -> Health:
        """The rule's state at ``now`` for /diagnostics: OK while alive,
        ERROR with the verdict's reason (the CPM NACKs) otherwise."""
        v = self.verdict(now)
        beat = self.last
        values: tuple[tuple[str, str], ...] = (
            ('dpm_timeout', text(self.dpm_timeout)),
            ('sensor_timeout', text(self.sensor_timeout)),
            ('driver_statuses_rejected', text(self.driver_rejected)))
        if beat is not None:
            values += (('dpm_state_age', text(now - beat.received)),
                       ('sensor', beat.input),
                       ('samples', text(beat.samples)),
                       ('sample_age', text(beat.sample_age
                                           + now - beat.received)),
                       ('rate', text(beat.rate, '%.1f')))
        if not v.ok:
            return Health(ERROR, v.reason + ': NACKs', values)
        if self.sensor_timeout is None or beat is None:
            return Health(OK, 'dpm alive', values)
        return Health(OK, 'dpm alive, sensor %s at %s Hz'
                      % (beat.input, text(beat.rate, '%.1f')), values)


class SampleMeter:
    """The DPM side: samples seen, the last one's arrival, the recent
    rate (over the last ``window`` s), all on the DPM's local clock."""

    def __init__(self, window: float = 2.0) -> None:
        self.window = window
        self.samples = 0
        self.arrivals: deque[float] = deque()

    def on_sample(self, local: float) -> None:
        """A sample arrived at local time ``local``."""
        self.samples += 1
        self.arrivals.append(local)
        while self.arrivals[0] < local - self.window:
            self.arrivals.popleft()

    def state(self, now: float) -> tuple[int, float, float]:
        """(samples, age of the last sample, rate in Hz) at ``now``; the
        age is NaN before the first sample, the rate NaN with fewer than
        two samples in the last ``window`` s."""
        if not self.arrivals:
            return self.samples, math.nan, math.nan
        age = now - self.arrivals[-1]
        recent = [t for t in self.arrivals if t >= now - self.window]
        if len(recent) < 2 or recent[-1] <= recent[0]:
            return self.samples, age, math.nan
        return (self.samples, age,
                (len(recent) - 1) / (recent[-1] - recent[0]))
