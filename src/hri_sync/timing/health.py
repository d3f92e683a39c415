"""Health of the timing model's nodes for /diagnostics, from plain values.

No ROS, no clock of its own: every time is passed in.  Each check returns
a ``Health``: a level (``OK``, ``WARN`` or ``ERROR``, the values of
diagnostic_msgs/DiagnosticStatus), a one-line message saying why, and
ordered (key, text) pairs.

- ``clock_health``: a host's clock model (a ``clock_sync.ClockStatus``):
  synced or not and why, the uncertainty against its limit, the time since
  the last good sync, drift and offset.
- ``RoundTally``: what a node did in its rounds, counted per outcome (and
  per client), and the last round's outcome with its reason; one for
  each role: ``client_tally`` (CPM), ``ServerTally`` (CM),
  ``result_tally`` (DPM), ``DecisionTally`` (DM).
- ``clock_state_health``: the clock a node reads from a ClockState (the
  DPM's from its CPM, the DM's from the server).
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
from typing import Any, TYPE_CHECKING

from hri_sync.timing.control import DECIDED, NO_DECISION, SHUTDOWN
from hri_sync.timing.vocabulary import Outcome, ResultStatus, RoundState

if TYPE_CHECKING:
    from hri_sync.timing.times import LocalTime
    from hri_sync.timing.clock import ClockModel
    from hri_sync.timing.clock_sync import ClockStatus


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


def clock_health(status: ClockStatus, local_now: LocalTime,
                 max_uncertainty: float | None = None,
                 stale_after: float | None = None,
                 near: float = 0.8) -> Health:
    """The health of a host's clock at local time ``local_now``.

    ``status`` is a ``ClockStatus`` (``model``, ``error``, ``samples``);
    ``max_uncertainty`` (s) is the limit past which the client NACKs
    (None: no limit), ``stale_after`` (s) how long a good sync may be
    ago before it is overdue (None: never).  ERROR: no model, or its
    uncertainty now exceeds the limit.  WARN: holdover (the last
    measurement failed), a sync overdue, or the uncertainty above
    ``near`` times the limit.  Else OK.
    """
    model = status.model
    synced = model.ready
    limit_ms = None if max_uncertainty is None else max_uncertainty * 1e3
    if synced:
        unc_ms = model.uncertainty_at(local_now) * 1e3
        since = local_now - model.local_ref
        drift_ppm = model.drift * 1e6
        offset_ms = model.offset_at(local_now) * 1e3
    else:
        unc_ms, since, drift_ppm, offset_ms = math.inf, math.nan, math.nan, \
            math.nan
    error = status.error
    if not synced:
        level = ERROR
        reason = 'not synced: %s' % (error or 'not measured yet')
    elif limit_ms is not None and unc_ms > limit_ms:
        level = ERROR
        reason = ('uncertainty %.3f ms exceeds its limit %.3f ms'
                  % (unc_ms, limit_ms))
        if error:
            reason += '; no good sync for %.1f s: %s' % (since, error)
    elif error:
        level = WARN
        reason = ('holdover: no good sync for %.1f s (%s); uncertainty '
                  '%.3f ms' % (since, error, unc_ms))
        if limit_ms is not None:
            reason += ' of %.3f ms' % limit_ms
    elif stale_after is not None and since > stale_after:
        level = WARN
        reason = ('last good sync %.1f s ago, more than %.1f s'
                  % (since, stale_after))
    elif limit_ms is not None and unc_ms > near * limit_ms:
        level = WARN
        reason = ('uncertainty %.3f ms near its limit %.3f ms'
                  % (unc_ms, limit_ms))
    else:
        level, reason = OK, ''
    if level == OK:
        message = 'synced: uncertainty %.3f ms' % unc_ms
        if limit_ms is not None:
            message += ' (limit %.3f ms)' % limit_ms
        message += ', drift %+.2f ppm' % drift_ppm
    else:
        message = reason
    return Health(level, message, (
        ('synced', text(synced)),
        ('reason', reason),
        ('uncertainty_ms', text(unc_ms)),
        ('max_uncertainty_ms', text(limit_ms)),
        ('since_last_sync_s', 'never' if math.isnan(since)
         else text(since, '%.1f')),
        ('drift_ppm', text(drift_ppm, '%+.3f')),
        ('offset_ms', text(offset_ms)),
        ('samples', text(status.samples)),
        ('last_error', error)))


def clock_state_health(source: str, model: ClockModel | None, reason: str,
                       samples: int, local_now: LocalTime,
                       age: float | None,
                       stale_after: float | None = None) -> Health:
    """The health of a clock a node reads from a ClockState (the DPM from
    its CPM, the DM from the server).

    ``model`` is the ClockModel it carries (None: none received yet, or
    one with ok false, then ``reason`` says why), ``samples`` its NTP
    bursts, ``age`` the s since the last ClockState arrived (the sender
    republishes after every sync), ``stale_after`` how old it may get
    (None: any age).  ERROR without a model, WARN when the ClockState is
    old or says holdover, else OK.
    """
    values = [('synced', text(model is not None))]
    if model is None:
        level = ERROR
        message = ('not synced: %s' % reason if reason
                   else 'no clock_state from %s yet' % source)
        unc, since, drift, offset = math.inf, math.nan, math.nan, math.nan
    else:
        unc = model.uncertainty_at(local_now) * 1e3
        since = local_now - model.local_ref
        drift = model.drift * 1e6
        offset = model.offset_at(local_now) * 1e3
        if stale_after is not None and age is not None \
                and age > stale_after:
            level = WARN
            message = ('no clock_state from %s for %.1f s, more than %.1f s'
                       % (source, age, stale_after))
        elif reason:
            level, message = WARN, reason
        else:
            level = OK
            message = ('synced: uncertainty %.3f ms, drift %+.2f ppm'
                       % (unc, drift))
    values += [
        ('reason', '' if level == OK else message),
        ('uncertainty_ms', text(unc)),
        ('since_last_sync_s', 'never' if math.isnan(since)
         else text(since, '%.1f')),
        ('drift_ppm', text(drift, '%+.3f')),
        ('offset_ms', text(offset)),
        ('samples', text(samples)),
        ('clock_state_age_s', 'never' if age is None else text(age, '%.1f'))]
    return Health(level, message, tuple(values))


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


def client_tally() -> RoundTally:
    """A CPM's rounds: its answers to sync_time and its capture orders.

    A NACK or a late capture order leaves the status at WARN until the
    next round (the clock's own status says ERROR while it cannot sync).
    """
    return RoundTally(('acked', 'nacked', 'scheduled', ResultStatus.LATE),
                      {'nacked': WARN, ResultStatus.LATE: WARN})


class ServerTally(RoundTally):
    """The CM's rounds: their state changes and how each ended.

    An abort or a shutdown mid-round is WARN, a round captured without a
    decision ERROR (the DM did not answer); per client of ``clients``,
    NACKs ('refused') and missing ACKs.  The events are those of the
    CM's ``timing.control.ControlSession``: its status updates and its
    round ends.
    """

    def __init__(self, clients: list[str] | tuple[()] = ()) -> None:
        super().__init__(
            (RoundState.SYNCING, RoundState.CAPTURING, DECIDED,
             RoundState.ABORTED, NO_DECISION, SHUTDOWN),
            {RoundState.ABORTED: WARN, NO_DECISION: ERROR, SHUTDOWN: WARN},
            client_outcomes=('refused', 'missing'), clients=clients)

    def on_status(self, round_id: int, state: str, reason: str,
                  refused: list[Any], missing: list[Any]) -> None:
        """A round's state change ('syncing', 'capturing' or 'aborted', as
        on /round_status); once the ACKs are in, count who refused or is
        missing."""
        self.record(round_id, state, reason)
        if state != RoundState.SYNCING:
            self.count('refused', refused)
            self.count('missing', missing)

    def on_end(self, round_id: int, outcome: str, message: str) -> None:
        """How a round ended: 'decided', 'aborted', 'no_decision' or
        'shutdown' (an abort its status update announced is not counted
        twice)."""
        last = self.last
        if outcome == RoundState.ABORTED and last and last[:2] == (
                round_id, RoundState.ABORTED):
            return
        self.record(round_id, outcome, message)


def result_tally() -> RoundTally:
    """A DPM's results by ClientResult status: partial and no_data are
    WARN, error ERROR, while they are the last round's."""
    return RoundTally(ResultStatus.ALL, {
        ResultStatus.PARTIAL: WARN, ResultStatus.NO_DATA: WARN,
        ResultStatus.LATE: WARN, ResultStatus.ERROR: ERROR})


class DecisionTally(RoundTally):
    """The DM's decisions by outcome (an abort is WARN) and, per
    participant, its results by status and the results that never came
    ('missing').  A status that is not a ClientResult status is counted
    as 'error'."""

    def __init__(self, participants: list[str]) -> None:
        super().__init__(Outcome.ALL, {Outcome.ABORTED: WARN},
                         client_outcomes=ResultStatus.ALL + ('missing',),
                         clients=participants)
        self._reported: dict[int, set[str]] = {}  # open round -> clients

    def on_result(self, round_id: int, client_id: str, status: str) -> None:
        """A result the DM took into round ``round_id``."""
        with self._lock:
            self._reported.setdefault(round_id, set()).add(client_id)
        self.count(status if status in ResultStatus.ALL
                   else ResultStatus.ERROR,
                   [client_id])

    def on_decision(self, round_id: int, outcome: str, reason: str,
                    count_missing: bool = True) -> None:
        """The decision of ``round_id``; the participants without a
        result are counted missing unless ``count_missing`` is false (the
        CM aborted the round before its capture: nobody was asked)."""
        with self._lock:
            reported = self._reported.pop(round_id, set())
        if count_missing:
            self.count('missing', [c for c in self.clients
                                   if c not in reported])
        self.record(round_id, outcome, reason)


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
