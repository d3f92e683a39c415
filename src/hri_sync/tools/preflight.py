"""Preflight check of a site before a session: go or no-go, with reasons.

The core of ``nodes/preflight`` (no ROS). The node listens for a few
seconds and fills a ``Site``: for every expected client its latest
``/<id>/clock_state`` (up, synced, uncertainty, drift), for each sensor
client the number of its sensor's messages and, for a tracker, the
device-clock fit from its ``/diagnostics``; the number of the robot's
``/odom`` messages; and one SNTP burst of the time server. ``assess``
turns that into a ``Report``: one line per client and the verdict, no-go
naming every reason.

The host clocks (``hri_sync.clock.host_clock``, docs/host_clocks.md):
the system clock of preflight's own host (that SNTP burst, chrony's
estimate) and of each client's (its CPM's ``host_clock`` status on
/diagnostics, else its clock model's offset) against the time server, one
line each; an offset above ``Limits.system_clock_warn`` is a warning
(printed, not a no-go: hri_sync's own stamps do not use the system
clock), above ``system_clock_error`` too unless ``system_clock_no_go``.
"""

import math
from dataclasses import dataclass, field

from hri_sync.clock import host_clock as hostclock
from hri_sync.wire.health import ERROR, LEVEL_NAMES, OK
from hri_sync.wire.vocabulary import MAX_UNCERTAINTY


@dataclass
class Limits:
    """What a site must meet to be go."""

    max_uncertainty: float = MAX_UNCERTAINTY  # s, a client's clock (its CPM's)
    max_drift: float = 1e-3            # dimensionless: 1000 ppm
    min_sensor_rate: float = 5.0       # Hz
    min_odom_rate: float = 1.0         # Hz
    system_clock_warn: float = hostclock.WARN_OFFSET    # s
    system_clock_error: float = hostclock.ERROR_OFFSET  # s
    system_clock_no_go: bool = False   # an ERROR offset is a no-go


@dataclass
class Clock:
    """A client's latest ClockState."""

    ok: bool
    reason: str = ''
    uncertainty: float = math.nan      # s
    drift: float = math.nan            # dimensionless
    samples: int = 0
    offset: float = math.nan           # s, global minus local at local_ref


@dataclass
class Client:
    """What was seen of one expected client."""

    client_id: str
    clock: Clock = None                # None: no clock_state (not up)
    sensor_topic: str = ''             # '' : not a sensor client
    sensor_messages: int = 0           # seen in the window
    device_clock: dict = None          # tracker diagnostics' device_clock_*
    host_clock: dict = None            # its CPM's host_clock status values


@dataclass
class Site:
    """One preflight's observations over ``window`` seconds."""

    window: float
    time_server: str                   # host:port
    time_server_error: str = None      # None: it answered
    clients: list = field(default_factory=list)
    robot_id: str = ''                 # '' : no robot expected
    odom_messages: int = 0             # seen in the window
    host_clock: hostclock.HostClock = None   # preflight's own host


@dataclass
class Report:
    """The verdict and the lines that explain it."""

    go: bool
    lines: list
    reasons: list
    warnings: list = field(default_factory=list)

    def text(self):
        verdict = 'GO' if self.go else 'NO-GO: ' + '; '.join(self.reasons)
        return '\n'.join(self.lines + ['warning: ' + w for w in
                                       self.warnings]
                         + ['preflight: ' + verdict])


def rate(count, window):
    """Messages per second over the listening window."""
    return count / window if window > 0 else 0.0


def assess(site, limits=None):
    """A Report of ``site`` against ``limits`` (default ``Limits()``)."""
    limits = limits or Limits()
    lines, reasons = [], []
    if site.time_server_error is None:
        lines.append('time server %s: answers' % site.time_server)
    else:
        lines.append('time server %s: NOT REACHED (%s)'
                     % (site.time_server, site.time_server_error))
        reasons.append('time server unreachable: %s'
                       % site.time_server_error)
    for c in site.clients:
        line, why = _client(c, site.window, limits)
        lines.append(line)
        reasons += why
    clock_lines, clock_reasons, warnings = _host_clocks(site, limits)
    lines += clock_lines
    reasons += clock_reasons
    if site.robot_id:
        hz = rate(site.odom_messages, site.window)
        lines.append('robot %s: /odom %.1f Hz' % (site.robot_id, hz))
        if hz < limits.min_odom_rate:
            reasons.append('robot %s does not answer: /odom %.1f Hz in '
                           '%.1f s (needs %.1f)' % (
                               site.robot_id, hz, site.window,
                               limits.min_odom_rate))
    return Report(not reasons, lines, reasons, warnings)


def _host_clocks(site, limits):
    """(lines, no-go reasons, warnings) of every host clock of ``site``."""
    lines, reasons, warnings = [], [], []
    clocks = [('this host', site.host_clock)] if site.host_clock else []
    clocks += [(c.client_id, client_host_clock(c)) for c in site.clients]
    for who, hc in clocks:
        if hc is None:
            continue
        h = hostclock.health(hc, limits.system_clock_warn,
                             limits.system_clock_error)
        values = dict(h.values)
        lines.append('%s (host %s): %s %s; model %s, chrony %s' % (
            who, hc.host, LEVEL_NAMES[h.level], h.message,
            values['model_offset_ms'], values['chrony_offset_ms']))
        if h.level == OK:
            continue
        what = '%s (host %s): %s' % (who, hc.host, h.message)
        if h.level == ERROR and limits.system_clock_no_go:
            reasons.append(what)
        else:
            warnings.append(what)
    return lines, reasons, warnings


def _float_ms(text):
    """Seconds of a '+1.234 ms' value; NaN for anything else."""
    try:
        return float(str(text).split()[0]) * 1e-3
    except (ValueError, IndexError):
        return math.nan


def client_host_clock(c):
    """The HostClock of client ``c``'s host: its CPM's host_clock status
    if seen, else its clock model's offset (the CPM's local clock is the
    system clock); None when neither is known."""
    model = c.clock.offset if c.clock is not None and c.clock.ok \
        else math.nan
    d = c.host_clock
    if not d:
        if not math.isfinite(model):
            return None
        return hostclock.HostClock(c.client_id, model_offset=model)
    chrony_text = d.get('chrony_offset_ms', 'not asked')
    chrony = None if chrony_text == 'not asked' else (
        hostclock.Chrony(_float_ms(chrony_text))
        if math.isfinite(_float_ms(chrony_text))
        else hostclock.Chrony(reason=chrony_text))
    return hostclock.HostClock(
        d.get('host', c.client_id), _float_ms(d.get('system_clock_offset_ms')),
        _float_ms(d.get('system_clock_round_trip_ms')),
        d.get('system_clock_error', ''), model, chrony)


def _client(c, window, limits):
    """(report line, no-go reasons) of one client."""
    cid, parts, why = c.client_id, [], []
    if c.clock is None:
        parts.append('NOT UP (no /%s/clock_state)' % cid)
        why.append('%s is not up: no /%s/clock_state' % (cid, cid))
    elif not c.clock.ok:
        parts.append('clock NOT SYNCED (%s)' % c.clock.reason)
        why.append('%s clock not synced: %s' % (cid, c.clock.reason))
    else:
        parts.append('clock +/-%.2f ms, drift %+.1f ppm (%d bursts)' % (
            c.clock.uncertainty * 1e3, c.clock.drift * 1e6,
            c.clock.samples))
        if not c.clock.uncertainty <= limits.max_uncertainty:
            why.append('%s clock uncertainty %.2f ms > %.2f ms' % (
                cid, c.clock.uncertainty * 1e3,
                limits.max_uncertainty * 1e3))
        if not abs(c.clock.drift) <= limits.max_drift:
            why.append('%s clock drift %+.0f ppm beyond +/-%.0f ppm' % (
                cid, c.clock.drift * 1e6, limits.max_drift * 1e6))
    if c.sensor_topic:
        hz = rate(c.sensor_messages, window)
        parts.append('sensor %s %.1f Hz' % (c.sensor_topic, hz))
        if hz < limits.min_sensor_rate:
            why.append('%s sensor %s %s: %.1f Hz in %.1f s (needs %.1f)' % (
                cid, c.sensor_topic,
                'silent' if not c.sensor_messages else 'too slow', hz,
                window, limits.min_sensor_rate))
    if c.device_clock:
        parts.append('device clock ' + ', '.join(
            '%s %s' % (k, v) for k, v in sorted(c.device_clock.items())))
    return '%s: %s' % (cid, '; '.join(parts)), why
