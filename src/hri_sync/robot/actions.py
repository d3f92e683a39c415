"""Configured actions at round events on the global clock.

No ROS and no clock of its own: ``nodes/action_client`` is the shell.

- ``parse_actions`` turns the YAML list of ``~actions`` into
  :class:`ActionSpec` s, or raises :class:`ConfigError` naming the action
  and the key that is wrong.
- :class:`ActionScheduler` turns the round's events (a capture order's
  window, a decision) into :class:`Firing` s: an action and the global
  time it is due at (the window start or end, or the decision's stamp,
  plus the action's offset), filtered by the decision's outcome and
  winner.
- :class:`ActionTally` keeps what they did for /diagnostics.
- :func:`run_firing` waits for a firing on the injected clock, runs it
  through the shell's ``execute`` and judges its start
  (:class:`StartReport`: OK within the action's tolerance, LATE after
  it, FAILED when it did not begin, each with its reason).
- :func:`await_end` waits for the end of a firing that began (the
  shell's :class:`Ending`) for the action's ``timeout`` and judges it
  (:class:`EndReport`: OK, FAILED with why, or TIMEOUT, the action
  aborted).
"""
import math
import re
import shlex
import threading
import time
from collections import Counter
from dataclasses import dataclass, field
from typing import Any, Dict, List, NamedTuple, Optional, Tuple

from hri_sync.wire.health import ERROR, OK, WARN, Health, text
from hri_sync.wire.vocabulary import Action, ActionEnd, Outcome

TOLERANCE = 0.005        # s, default: a start later than this is LATE
# s, defaults of an action's `timeout`: no end this long after its start
# is TIMEOUT (a publish ends when it is sent: it has none).
SERVICE_TIMEOUT = 5.0    # the service's answer
ACTIONLIB_TIMEOUT = 30.0     # the goal's result
COMMAND_TIMEOUT = 30.0   # the process's exit
END_POLL = 0.01          # s between looks for an action's end
TIMEOUTS = {Action.SERVICE: SERVICE_TIMEOUT,
            Action.ACTIONLIB: ACTIONLIB_TIMEOUT,
            Action.COMMAND: COMMAND_TIMEOUT}
NAME = re.compile(r'^[A-Za-z][A-Za-z0-9_]*$')
TYPE = re.compile(r'^[A-Za-z][A-Za-z0-9_]*/[A-Za-z][A-Za-z0-9_]*$')
ROS_NAME = re.compile(r'^[~/]?[A-Za-z][A-Za-z0-9_/]*$')
COMMON = {'name', 'at', 'offset', 'tolerance', 'max_late', 'outcomes',
          'winners'}      # and `timeout`, but for a publish
# kind: (the key that names it, the keys of its mapping or None for a list)
KIND_KEYS = {
    Action.PUBLISH: ('topic', 'type', 'fields'),
    Action.SERVICE: ('service', 'type', 'request'),
    Action.ACTIONLIB: ('server', 'type', 'goal'),
}


class ConfigError(ValueError):
    """A configured action that is wrong, and why."""


class ActionFailed(Exception):
    """Raised by the shell's ``execute``: the action did not begin."""


@dataclass(frozen=True)
class ActionSpec:
    """One configured action.

    ``target``: the topic, service or action server; ``type``: its
    message, service or action type (``pkg/Name``); ``fields``: the
    message's, request's or goal's fields; ``command``: the argv of a
    command (run without a shell); ``timeout``: s its end is awaited
    after its start (0: a publish, which ends at once)."""

    name: str
    kind: str                       # Action.KINDS
    event: str                      # Action.EVENTS
    offset: float = 0.0             # s after the event
    tolerance: float = TOLERANCE
    max_late: Optional[float] = None    # s; later: not run (None: any)
    timeout: float = 0.0
    outcomes: Tuple[str, ...] = ()  # decision: the outcomes it fires on
    winners: Tuple[int, ...] = ()   # decision: the winners it fires on
    target: str = ''
    type: str = ''
    fields: Dict[str, Any] = field(default_factory=dict)
    command: Tuple[str, ...] = ()

    def matches(self, outcome, winner):
        """Whether a decision (outcome, winner) fires this action."""
        return ((not self.outcomes or outcome in self.outcomes)
                and (not self.winners or winner in self.winners))


def _number(item, key, default, check, why):
    value = item.get(key, default)
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, float)) \
            or not math.isfinite(value) or not check(value):
        raise ConfigError('%s=%r: %s' % (key, value, why))
    return float(value)


def _list(item, key, allowed, why):
    value = item.get(key, [])
    value = value if isinstance(value, list) else [value]
    bad = [v for v in value if not allowed(v)]
    if bad:
        raise ConfigError('%s: %r %s' % (key, bad, why))
    return tuple(value)


def _kind(item):
    """(kind, its keys) of an action: the one kind key it has."""
    kinds = [k for k in Action.KINDS if k in item]
    if len(kinds) != 1:
        raise ConfigError('needs exactly one of %s, has %s'
                          % (', '.join(Action.KINDS), kinds or 'none'))
    return kinds[0]


def _command(value):
    """A command's argv from a list or a string (split like a shell
    would, but never run by one)."""
    if isinstance(value, str):
        try:
            value = shlex.split(value)
        except ValueError as e:
            raise ConfigError('command: %s' % e)
    if not isinstance(value, list) or not value or not all(
            isinstance(a, (str, int, float)) and not isinstance(a, bool)
            for a in value) or not str(value[0]):
        raise ConfigError('command: %r is not a non-empty list of '
                          'arguments' % (value,))
    return tuple(str(a) for a in value)


def _target(kind, body):
    """(target, type, fields) of a publish, service or actionlib action."""
    if not isinstance(body, dict):
        raise ConfigError('%s: needs a mapping of %s' % (
            kind, ', '.join(KIND_KEYS[kind])))
    name_key, type_key, fields_key = KIND_KEYS[kind]
    unknown = set(body) - set(KIND_KEYS[kind])
    if unknown:
        raise ConfigError('%s: unknown keys %s' % (kind, sorted(unknown)))
    target, kind_type = body.get(name_key), body.get(type_key)
    if not isinstance(target, str) or not ROS_NAME.match(target):
        raise ConfigError('%s.%s=%r is not a ROS name' % (kind, name_key,
                                                          target))
    if not isinstance(kind_type, str) or not TYPE.match(kind_type):
        raise ConfigError('%s.%s=%r is not a type (pkg/Name)'
                          % (kind, type_key, kind_type))
    if kind == Action.ACTIONLIB and not kind_type.endswith('Action'):
        raise ConfigError('actionlib.type=%r is not an action type '
                          '(pkg/NameAction)' % kind_type)
    fields = body.get(fields_key) or {}
    if not isinstance(fields, dict):
        raise ConfigError('%s.%s=%r is not a mapping of fields'
                          % (kind, fields_key, fields))
    return target, kind_type, fields


def parse_action(item, tolerance=TOLERANCE):
    """One ``~actions`` entry as an ActionSpec (ConfigError if wrong)."""
    if not isinstance(item, dict):
        raise ConfigError('an action is a mapping, got %r' % (item,))
    name = item.get('name')
    if not isinstance(name, str) or not NAME.match(name):
        raise ConfigError('name=%r: a letter, then letters, digits or _'
                          % (name,))
    try:
        kind = _kind(item)
        unknown = set(item) - COMMON - {kind, 'timeout'}
        if unknown:
            raise ConfigError('unknown keys %s' % sorted(unknown))
        event = item.get('at')
        if event not in Action.EVENTS:
            raise ConfigError('at=%r is not one of %s'
                              % (event, ', '.join(Action.EVENTS)))
        outcomes = _list(item, 'outcomes', Outcome.ALL.__contains__,
                         'not among %s' % ', '.join(Outcome.ALL))
        winners = _list(item, 'winners', lambda w: isinstance(w, int)
                        and not isinstance(w, bool) and 0 <= w <= 255,
                        'not participant numbers (1.., 0: none)')
        if event != Action.DECISION and (outcomes or winners):
            raise ConfigError('outcomes and winners filter decisions only')
        if kind == Action.PUBLISH and 'timeout' in item:
            raise ConfigError('timeout: a publish ends when it is sent')
        spec = dict(
            name=name, kind=kind, event=event,
            offset=_number(item, 'offset', 0.0, lambda x: True, 's'),
            tolerance=_number(item, 'tolerance', tolerance,
                              lambda x: x >= 0, '>= 0 s'),
            max_late=_number(item, 'max_late', None, lambda x: x >= 0,
                             '>= 0 s'),
            timeout=0.0 if kind == Action.PUBLISH else _number(
                item, 'timeout', TIMEOUTS[kind], lambda x: x > 0, '> 0 s'),
            outcomes=outcomes, winners=winners)
        if kind == Action.COMMAND:
            return ActionSpec(command=_command(item[kind]), **spec)
        target, kind_type, fields = _target(kind, item[kind])
        return ActionSpec(target=target, type=kind_type, fields=fields,
                          **spec)
    except ConfigError as e:
        raise ConfigError('action %s: %s' % (name, e))


def parse_actions(items, tolerance=TOLERANCE):
    """The ``~actions`` list as ActionSpec s; names must be unique."""
    if not isinstance(items, list) or not items:
        raise ConfigError('~actions must be a non-empty list of actions, '
                          'got %r' % (items,))
    specs = [parse_action(i, tolerance) for i in items]
    names = [s.name for s in specs]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise ConfigError('action names used twice: %s' % ', '.join(twice))
    return specs


class Firing(NamedTuple):
    """An action due at global time ``scheduled`` in round ``round``;
    ``note`` says why it is known to be late already."""

    action: ActionSpec
    round: int
    scheduled: float
    note: str = ''


class ActionScheduler:
    """Round events to firings.  Each round's window and decision count
    once (a repeat is ignored and logged); ``log(level, text)``."""

    KEEP = 100           # rounds remembered against repeats

    def __init__(self, actions, log=lambda level, text: None):
        self.actions = list(actions)
        self.log = log
        self.windows: List[int] = []
        self.decided: List[int] = []

    @staticmethod
    def _first(seen, round_id):
        if round_id in seen:
            return False
        seen.append(round_id)
        del seen[:-ActionScheduler.KEEP]
        return True

    def on_capture(self, round_id, start, end):
        """A capture window [start, end) (global): its actions' firings."""
        if not self._first(self.windows, round_id):
            self.log('warn', 'round %d: a second window ignored' % round_id)
            return []
        base = {Action.WINDOW_START: start, Action.WINDOW_END: end}
        return sorted((Firing(a, round_id, base[a.event] + a.offset)
                       for a in self.actions if a.event in base),
                      key=lambda f: f.scheduled)

    def on_late(self, round_id, start, end, reason):
        """A capture order that came after its window started: its
        actions still fire, late, saying why."""
        return [f._replace(note='the capture order came late: ' + reason)
                for f in self.on_capture(round_id, start, end)]

    def on_decision(self, round_id, outcome, winner, stamp, now):
        """A decision at global ``stamp`` (0: unknown, then ``now``, the
        receipt): the firings of the actions its outcome and winner
        match."""
        if not self._first(self.decided, round_id):
            self.log('warn', 'round %d: a second decision ignored'
                     % round_id)
            return []
        note = ''
        if not stamp > 0:
            stamp, note = now, 'the decision had no stamp: timed from ' \
                'its receipt'
        return sorted((Firing(a, round_id, stamp + a.offset, note)
                       for a in self.actions if a.event == Action.DECISION
                       and a.matches(outcome, winner)),
                      key=lambda f: f.scheduled)


class Ending:
    """The end of an action that began, as the shell sees it.

    The shell's thread or callback calls :meth:`finish` once, when it
    ended (``error``: why it ended badly; None: well); a subclass's
    :meth:`abort` stops an action that did not end in time.  ``now()``:
    the global clock, read at the end; ``sleep(s)`` between looks for
    it.  The first of the end and the timeout wins (thread-safe)."""

    def __init__(self, now, sleep=time.sleep):
        self.now = now
        self.sleep = sleep
        self._lock = threading.Lock()
        self._done = threading.Event()
        self.ended: Optional[float] = None
        self.error: Optional[str] = None
        self.note = ''

    def finish(self, error=None, note=''):
        """It ended now; False if it had already ended or timed out."""
        with self._lock:
            if self._done.is_set():
                return False
            self.ended, self.error, self.note = self.now(), error, note
            self._done.set()
            return True

    def wait(self, seconds):
        """Whether it ended within ``seconds`` on the global clock; looks
        every END_POLL s (a timed wait on a condition can last forever
        under libfaketime; the end's time is read when it comes)."""
        deadline = self.now() + seconds
        while not self._done.is_set():
            left = deadline - self.now()
            if left <= 0:
                return False
            self.sleep(min(END_POLL, left))
        return True

    def expire(self):
        """Marks it timed out: False if it ended meanwhile."""
        with self._lock:
            if self._done.is_set():
                return False
            self._done.set()
            return True

    def abort(self):
        """Stops it (it timed out); returns what was done ('' nothing)."""
        return ''


class Begun(NamedTuple):
    """What the shell's ``execute`` returns for an action it began: a
    ``note`` on its start, and its ``ending`` (None: it ended at once)."""

    note: str = ''
    ending: Optional[Ending] = None


class StartReport(NamedTuple):
    """How a firing began: ``actual`` (global), ``local`` and ``true``
    (the host's clocks) at the instant, ``status`` and ``reason``;
    ``ending``: the shell's, when it began and has not ended yet."""

    firing: Firing
    actual: float
    local: float
    true: float
    status: str
    reason: str
    ending: Optional[Ending] = None

    @property
    def offset(self):
        """actual - scheduled, s."""
        return self.actual - self.firing.scheduled


def judge(firing, actual, error=None, note=''):
    """(status, reason) of a firing that began at ``actual`` (global), or
    failed with ``error``; ``note``: what the shell said of its start."""
    if error is not None:
        return Action.FAILED, str(error) or type(error).__name__
    notes = [n for n in (firing.note, note) if n]
    late = actual - firing.scheduled
    tolerance = firing.action.tolerance
    if late > tolerance:
        notes.insert(0, 'began %.2f ms after its scheduled time (tolerance '
                     '%.2f ms)' % (late * 1e3, tolerance * 1e3))
        return Action.LATE, '; '.join(notes)
    return Action.OK, '; '.join(notes)


def run_firing(firing, now, wait, execute, host_clocks):
    """Wait for ``firing`` and run it: ``now()`` global time, ``wait(t)``
    blocks until global ``t`` (None: stopped), ``execute(action)`` begins
    it (returns a Begun; raises ActionFailed),
    ``host_clocks()`` (local, true).  Returns the
    StartReport, or None if stopped before it began.  A firing later than
    its action's ``max_late`` is not run (FAILED)."""
    max_late = firing.action.max_late
    if max_late is None or now() - firing.scheduled <= max_late:
        if wait(firing.scheduled) is None:
            return None
    local, true = host_clocks()
    actual = now()
    late = actual - firing.scheduled
    error: Optional[Exception] = None
    begun = Begun()
    if max_late is not None and late > max_late:
        error = ActionFailed('not run: %.1f ms after its scheduled time '
                             '(max_late %.1f ms)%s' % (
                                 late * 1e3, max_late * 1e3,
                                 '; ' + firing.note if firing.note else ''))
    else:
        try:
            begun = execute(firing.action)
        except ActionFailed as e:
            error = e
    status, reason = judge(firing, actual, error, begun.note)
    return StartReport(firing, actual, local, true, status, reason,
                       begun.ending)


class EndReport(NamedTuple):
    """How a firing that began ended: at ``ended`` (global), ``status``
    (ActionEnd.STATUSES) and ``reason``."""

    start: StartReport
    ended: float
    status: str
    reason: str

    @property
    def firing(self):
        """The firing that ended."""
        return self.start.firing

    @property
    def duration(self):
        """From its start to its end, s (global clock)."""
        return self.ended - self.start.actual


def judge_end(action, duration, error=None, note='', aborted=None):
    """(status, reason) of an end ``duration`` s after the start:
    TIMEOUT when it did not end within the action's timeout (``aborted``:
    what was done then), FAILED with ``error``, else OK (``note``)."""
    if aborted is not None:
        return ActionEnd.TIMEOUT, 'no end %.2f s after its start (timeout ' \
            '%g s)%s' % (duration, action.timeout,
                         ': ' + aborted if aborted else '')
    if error is not None:
        return ActionEnd.FAILED, error or 'failed'
    return ActionEnd.OK, note


def await_end(start, now):
    """Waits for the end of the firing that began as ``start`` says, at
    most its action's timeout after its start (global ``now()``), and
    judges it; a timed-out action is aborted.  None if it did not
    begin."""
    if start.status == Action.FAILED:
        return None
    action, ending = start.firing.action, start.ending
    if ending is None:
        return EndReport(start, now(), *judge_end(action, 0.0))
    remaining = start.actual + action.timeout - now()
    if ending.wait(max(0.0, remaining)) or not ending.expire():
        ended = ending.ended
        return EndReport(start, ended, *judge_end(
            action, ended - start.actual, ending.error, ending.note))
    aborted = ending.abort()
    ended = now()
    return EndReport(start, ended, *judge_end(
        action, ended - start.actual, aborted=aborted))


class ActionTally:
    """Every report's status, and each action's last start and end, as a
    /diagnostics status: ERROR while an action's last firing failed or
    its last end failed or timed out, WARN while one was late, else OK.
    Thread-safe."""

    def __init__(self):
        self._lock = threading.Lock()
        self.counts: Counter = Counter()
        self.end_counts: Counter = Counter()
        self.last: Dict[str, StartReport] = {}
        self.last_end: Dict[str, EndReport] = {}

    def record(self, report):
        """Count one StartReport."""
        with self._lock:
            self.counts[report.status] += 1
            self.last[report.firing.action.name] = report

    def record_end(self, report):
        """Count one EndReport."""
        with self._lock:
            self.end_counts[report.status] += 1
            self.last_end[report.firing.action.name] = report

    @staticmethod
    def _text(status, round_id, at, reason):
        return '%s in round %d %s%s' % (status, round_id, at,
                                        ': ' + reason if reason else '')

    def _values(self, counts, end_counts, last, last_end):
        values = tuple((s, text(counts.get(s, 0))) for s in Action.STATUSES)
        values += tuple(('ended_' + s, text(end_counts.get(s, 0)))
                        for s in ActionEnd.STATUSES)
        values += tuple((name, self._text(
            r.status, r.firing.round, 'at %+.2f ms' % (r.offset * 1e3),
            r.reason)) for name, r in sorted(last.items()))
        values += tuple((name + ' end', self._text(
            r.status, r.firing.round, 'after %.3f s' % r.duration,
            r.reason)) for name, r in sorted(last_end.items()))
        return values

    def health(self):
        """The Health of the actions' last firings and ends."""
        with self._lock:
            counts, end_counts = dict(self.counts), dict(self.end_counts)
            last, last_end = dict(self.last), dict(self.last_end)
        values = self._values(counts, end_counts, last, last_end)
        for level, found in (
                (ERROR, (('firing', Action.FAILED, last),
                         ('end', ActionEnd.FAILED, last_end),
                         ('end', ActionEnd.TIMEOUT, last_end))),
                (WARN, (('firing', Action.LATE, last),))):
            parts = []
            for what, status, reports in found:
                names = sorted(n for n, r in reports.items()
                               if r.status == status)
                if names:
                    parts.append('last %s %s: %s' % (what, status,
                                                     ', '.join(names)))
            if parts:
                return Health(level, '; '.join(parts), values)
        if not last:
            return Health(OK, 'no action fired yet', values)
        return Health(OK, 'last firings on time', values)
