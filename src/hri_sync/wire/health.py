"""A node's health for /diagnostics, as plain values.

No ROS, no clock of its own: every time is passed in.  Each check returns
a ``Health``: a level (``OK``, ``WARN`` or ``ERROR``, the values of
diagnostic_msgs/DiagnosticStatus), a one-line message saying why, and
ordered (key, text) pairs.  Each module's own checks stand beside it
(``clock.health``, ``control.health``, ``decision.health``,
``client_process.health``, ``data_process.health``).

- ``RoundTally``: what a node did in its rounds, counted per outcome (and
  per client), and the last round's outcome with its reason.
- ``RateMeter``: the rate a sensor's samples arrive at, and its silences.
- ``RejectionWatch``: counts of rejected input messages per
  (topic, reason); WARN while they grow.

``hri_sync.ros.diagnostics`` publishes them with diagnostic_updater.
"""

from __future__ import annotations

import math
import threading
from collections import Counter, deque
from dataclasses import dataclass
from typing import Any

OK, WARN, ERROR = 0, 1, 2      # diagnostic_msgs/DiagnosticStatus levels
LEVEL_NAMES = {OK: 'OK', WARN: 'WARN', ERROR: 'ERROR'}


@dataclass(frozen=True)
class Health:
    """One status: ``level``, ``message`` and ``values``, a tuple of
    (key, text) pairs in a fixed order."""

    level: int
    message: str
    values: tuple = ()

    def value(self, key: str) -> str:
        """The text of ``key``; KeyError if there is none."""
        for k, v in self.values:
            if k == key:
                return v
        raise KeyError(key)


def text(x: float | str | None, fmt: str = '%.3f') -> str:
    """A value as diagnostic text: booleans 'true'/'false', None 'none',
    floats with ``fmt`` (non-finite as 'nan', 'inf'), anything else str."""
    if x is None:
        return 'none'
    if isinstance(x, bool):
        return 'true' if x else 'false'
    if isinstance(x, float):
        return fmt % x if math.isfinite(x) else str(x)
    return str(x)


class RoundTally:
    """A node's rounds as /diagnostics shows them.

    ``record(round, outcome, reason)`` counts an event of a round (an ACK,
    a result, a decision...) and makes it the last one; ``count(outcome,
    clients)`` counts an outcome per client (a NACK, a missing result).
    ``outcomes`` are the outcomes counted (their counts are shown from
    0), ``levels`` the level of the status while an outcome is the last
    one (OK when not listed); the per-client counts of ``clients`` are
    shown from 0 too.  ``version`` grows at every change.  Thread-safe.
    """

    def __init__(self, outcomes: tuple[str, ...],
                 levels: dict[str, int] | None = None,
                 client_outcomes: tuple[str, ...] = (),
                 clients: list[str] | tuple[()] = ()) -> None:
        self.outcomes = tuple(outcomes)
        self.levels = dict(levels or {})
        self.client_outcomes = tuple(client_outcomes)
        self.clients = tuple(clients)
        unknown = set(self.levels) - set(self.outcomes)
        if unknown:
            raise ValueError('levels for outcomes not counted: %s'
                             % ', '.join(sorted(unknown)))
        self.counts: Counter[str] = Counter()
        self.per_client: Counter[tuple[str, str]] = Counter()
        self.last: tuple[int, str, str] | None = None  # round, outcome, why
        self.version = 0
        self._lock = threading.Lock()

    def record(self, round_id: int, outcome: str, reason: str = '') -> None:
        """Count ``outcome`` of round ``round_id``; it is now the last."""
        if outcome not in self.outcomes:
            raise ValueError('outcome %r is not one of %s'
                             % (outcome, ', '.join(self.outcomes)))
        with self._lock:
            self.counts[outcome] += 1
            self.last = (round_id, outcome, reason)
            self.version += 1

    def count(self, outcome: str, clients: list[Any]) -> None:
        """Count ``outcome`` once for each of ``clients``."""
        if outcome not in self.client_outcomes:
            raise ValueError('client outcome %r is not one of %s'
                             % (outcome, ', '.join(self.client_outcomes)))
        with self._lock:
            for c in clients:
                self.per_client[(c, outcome)] += 1
            self.version += 1

    def health(self) -> Health:
        """Level and message from the last round; every count."""
        with self._lock:
            last = self.last
            counts = dict(self.counts)
            per_client = dict(self.per_client)
        if last is None:
            level, message = OK, 'no round yet'
            values = [('last_round', 'none'), ('last_outcome', ''),
                      ('last_reason', '')]
        else:
            round_id, outcome, reason = last
            level = self.levels.get(outcome, OK)
            message = 'round %d: %s' % (round_id, outcome)
            if reason:
                message += ': %s' % reason
            values = [('last_round', text(round_id)),
                      ('last_outcome', outcome), ('last_reason', reason)]
        values += [('%s_count' % o, text(counts.get(o, 0)))
                   for o in self.outcomes]
        clients = list(self.clients) + sorted(
            {c for c, _ in per_client} - set(self.clients))
        values += [('%s %s_count' % (c, o), text(per_client.get((c, o), 0)))
                   for c in clients for o in self.client_outcomes]
        return Health(level, message, tuple(values))


class RateMeter:
    """The rate samples arrive at, over the last ``window`` s.

    ``observe(t)`` at each arrival, ``health(now)`` at any time: ERROR
    when no sample came yet or none for ``silent_after`` s, WARN below
    ``min_rate`` Hz (None: no minimum), else OK.  Times are of one clock
    of the caller's (a monotonic one in a node).  Thread-safe.
    """

    def __init__(self, topic: str, window: float = 5.0,
                 silent_after: float = 1.0,
                 min_rate: float | None = None) -> None:
        if not (math.isfinite(window) and window > 0):
            raise ValueError('rate window must be > 0 s, got %r' % (window,))
        if not (math.isfinite(silent_after) and silent_after > 0):
            raise ValueError('silent_after must be > 0 s, got %r'
                             % (silent_after,))
        self.topic = topic
        self.window = window
        self.silent_after = silent_after
        self.min_rate = min_rate
        self.total = 0
        self._times: deque[float] = deque()
        self._lock = threading.Lock()

    def observe(self, t: float) -> None:
        """A sample arrived at ``t``."""
        with self._lock:
            self.total += 1
            self._times.append(t)
            while self._times and self._times[0] < t - self.window:
                self._times.popleft()

    def rate(self, now: float) -> float:
        """Samples per s over the window ending at ``now`` (NaN with
        fewer than two samples in it)."""
        with self._lock:
            times = [t for t in self._times if t >= now - self.window]
        if len(times) < 2 or times[-1] <= times[0]:
            return math.nan
        return (len(times) - 1) / (times[-1] - times[0])

    def health(self, now: float) -> Health:
        """The sensor's health at ``now``."""
        with self._lock:
            last = self._times[-1] if self._times else None
            total = self.total
        rate = self.rate(now)
        silent = None if last is None else now - last
        if silent is None:
            level, message = ERROR, 'no sample on %s yet' % self.topic
        elif silent > self.silent_after:
            level = ERROR
            message = 'no sample on %s for %.1f s' % (self.topic, silent)
        elif (self.min_rate is not None and math.isfinite(rate)
              and rate < self.min_rate):
            level = WARN
            message = ('%s at %.1f Hz, below %.1f Hz'
                       % (self.topic, rate, self.min_rate))
        else:
            level = OK
            message = '%s at %s Hz' % (self.topic, text(rate, '%.1f'))
        return Health(level, message, (
            ('topic', self.topic),
            ('rate_hz', text(rate, '%.2f')),
            ('min_rate_hz', text(self.min_rate, '%.2f')),
            ('since_last_sample_s', 'never' if silent is None
             else text(silent, '%.2f')),
            ('samples_total', text(total))))


class RejectionWatch:
    """Rejected input for /diagnostics: counts per (topic, reason).

    ``health(counts, now)`` takes the counts as ``{'<topic> <reason>':
    n}`` (keys ending in ' accepted' are shown, not counted as
    rejections) and is WARN while the total grew in the last ``recent``
    s, else OK.  ``now`` is any clock of the caller's, the same at every
    call.
    """

    def __init__(self, recent: float = 60.0) -> None:
        self.recent = recent
        self.total = 0
        self.grew_at = -math.inf
        self._lock = threading.Lock()

    def health(self, counts: dict[str, int], now: float) -> Health:
        """Counts and level at ``now``."""
        counts = {str(k): int(n) for k, n in counts.items()}
        rejected = {k: n for k, n in counts.items()
                    if not k.endswith(' accepted')}
        total = sum(rejected.values())
        with self._lock:
            if total > self.total:
                self.grew_at = now
            self.total = total
            grew_at = self.grew_at
        values = (('rejected_total', text(total)),) + tuple(
            (k, text(n)) for k, n in sorted(counts.items()))
        if not total:
            return Health(OK, 'no message rejected', values)
        most = max(sorted(rejected), key=lambda k: rejected[k])
        message = '%d rejected (most: %s, %d)' % (total, most, rejected[most])
        if now - grew_at < self.recent:
            return Health(WARN, '%s; the last %.0f s ago'
                          % (message, now - grew_at), values)
        return Health(OK, '%s; none in the last %.0f s'
                      % (message, self.recent), values)
