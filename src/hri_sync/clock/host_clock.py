"""A host's system clock against the time server (docs/host_clocks.md).

hri_sync stamps with its software global clock (system clock + the model's
offset), so it does not need the system clock set. Every other node on the
host does: tf, rviz, message_filters and drivers stamp with the system
clock (``ros::Time::now()``). This module says how far that clock is from
the time server, beside the hri_sync model's offset and, where chronyd
runs, chrony's own estimate, and grades it:

- WARN above ``WARN_OFFSET`` (5 ms): a quarter of the 20 ms period of a
  50 Hz tf publisher and a sixth of a 30 Hz camera frame; other hosts'
  "now" lookups start to fail with tf extrapolation errors and
  message_filters' approximate sync starts to pair the wrong frames of
  cameras on different hosts.
- ERROR above ``ERROR_OFFSET`` (50 ms): more than two tf periods and a
  whole camera frame; lookups at "now" fail routinely.

No ROS, no clock or socket of its own: the SNTP burst (``ntp.measure``
with the system clock) and ``chronyc`` are injected.
"""
import math
import subprocess
from dataclasses import dataclass
from typing import Callable, Optional, Sequence, Tuple

from hri_sync.wire.health import ERROR, OK, WARN, Health

WARN_OFFSET = 0.005   # s
ERROR_OFFSET = 0.050  # s
CHRONYC = ('chronyc', '-c', 'tracking')
LOCAL_REFERENCE = '7F7F0101'   # chrony's reference id of 'local stratum'


@dataclass(frozen=True)
class Chrony:
    """chronyd's own view of this host's clock (``chronyc -c tracking``).

    ``offset`` is the time of its sources minus the system clock, s
    (chrony's "System time", positive when the clock is slow), NaN when
    ``reason`` says why there is none (no chronyd, not synchronised)."""

    offset: float = math.nan
    reference: str = ''
    stratum: int = 0
    leap: str = ''
    reason: str = ''

    @property
    def available(self) -> bool:
        """True when chrony gave an estimate."""
        return not self.reason


def parse_tracking(text: str) -> Chrony:
    """A Chrony from ``chronyc -c tracking``'s CSV line: reference id,
    name, stratum, reference time, system time, last offset, ... leap."""
    fields = text.strip().split(',')
    if len(fields) < 14:
        return Chrony(reason='chronyc said %r' % text.strip()[:120])
    try:
        offset, stratum = float(fields[4]), int(fields[2])
    except ValueError:
        return Chrony(reason='chronyc said %r' % text.strip()[:120])
    leap = fields[13]
    if fields[0].upper() == LOCAL_REFERENCE:
        return Chrony(reference='local', stratum=stratum, leap=leap,
                      reason='unavailable: chronyd here serves its own clock '
                      '(local stratum %d), it follows no source' % stratum)
    if stratum == 0 or leap.lower().startswith('not synch'):
        return Chrony(reference=fields[1], leap=leap,
                      reason='chronyd is not synchronised (%s)' % leap)
    return Chrony(offset, fields[1], stratum, leap)


def chrony_tracking(run: Callable = subprocess.run,
                    command: Sequence[str] = CHRONYC,
                    timeout: float = 2.0) -> Chrony:
    """Ask chronyd (``command``, run by ``run`` like subprocess.run);
    a Chrony whose ``reason`` says why when it cannot answer."""
    try:
        p = run(list(command), capture_output=True, text=True,
                timeout=timeout)
    except FileNotFoundError:
        return Chrony(reason='unavailable: chronyc is not installed')
    except (OSError, subprocess.SubprocessError) as e:
        return Chrony(reason='unavailable: %s' % e)
    if p.returncode != 0:
        said = (p.stdout + p.stderr).strip().splitlines()
        return Chrony(reason='unavailable: %s' % (
            said[-1] if said else 'chronyc exit %d' % p.returncode))
    return parse_tracking(p.stdout)


@dataclass(frozen=True)
class HostClock:
    """One host's system clock against the time server."""

    host: str
    system_offset: float = math.nan   # server minus system clock, s
    round_trip: float = math.nan      # of that measurement, s
    error: str = ''                   # why it was not measured
    model_offset: float = math.nan    # the hri_sync model's, s (NaN: none)
    chrony: Optional[Chrony] = None   # None: not asked


def measure(host: str, burst: Callable, model_offset: float = math.nan,
            chrony: Callable[[], Chrony] = chrony_tracking) -> HostClock:
    """A HostClock of this host: ``burst()`` is an SNTP burst of the
    system clock (``ntp.measure`` with ``time.time``; an
    OffsetMeasurement or raises), ``chrony()`` chronyd's view."""
    try:
        m = burst()
        offset, delay, error = m.offset, m.delay, ''
    except Exception as e:    # SyncError, OSError, ValueError: say it
        offset, delay, error = math.nan, math.nan, str(e) or repr(e)
    return HostClock(host, offset, delay, error, model_offset, chrony())


def _ms(x: float) -> str:
    return 'n/a' if not math.isfinite(x) else '%+.3f ms' % (x * 1e3)


def grade(offset: float, warn: float = WARN_OFFSET,
          error: float = ERROR_OFFSET) -> int:
    """OK, WARN or ERROR of a system clock ``offset`` (s; NaN: ERROR)."""
    if not math.isfinite(offset) or abs(offset) > error:
        return ERROR
    return WARN if abs(offset) > warn else OK


def health(h: HostClock, warn: float = WARN_OFFSET,
           error: float = ERROR_OFFSET) -> Health:
    """The /diagnostics status (and preflight line) of ``h``: graded by
    the measured system clock offset, else by chrony's, else the model's
    (the hri_sync model's local clock is the system clock)."""
    sources = ((h.system_offset, 'measured by SNTP'),
               (h.chrony.offset if h.chrony else math.nan, 'by chrony'),
               (h.model_offset, "by hri_sync's clock model"))
    offset, how = next(((o, w) for o, w in sources if math.isfinite(o)),
                       (math.nan, ''))
    level = grade(offset, warn, error)
    if math.isfinite(offset):
        message = ('system clock %s off the time server (%s)'
                   % (_ms(offset), how))
        if level != OK:
            message += ('; above %.0f ms: tf extrapolation errors and '
                        'mispaired message_filters between hosts; set it '
                        'with chrony (docs/host_clocks.md)'
                        % ((error if level == ERROR else warn) * 1e3))
    else:
        message = 'system clock offset unknown: %s' % (h.error or
                                                       'not measured')
    chrony = ('not asked' if h.chrony is None else _ms(h.chrony.offset)
              if h.chrony.available else h.chrony.reason)
    values: Tuple = (
        ('host', h.host),
        ('system_clock_offset_ms', _ms(h.system_offset)),
        ('system_clock_round_trip_ms', _ms(h.round_trip)),
        ('model_offset_ms', _ms(h.model_offset)),
        ('chrony_offset_ms', chrony),
        ('warn_above_ms', '%.1f' % (warn * 1e3)),
        ('error_above_ms', '%.1f' % (error * 1e3)))
    if h.error:
        values += (('system_clock_error', h.error),)
    return Health(level, message, values)
