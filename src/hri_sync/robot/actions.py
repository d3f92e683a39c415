"""Configured actions at round events on the global clock (issue 19).

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
"""
import math
import re
import shlex
import threading
from collections import Counter
from dataclasses import dataclass, field
from typing import Any, Dict, List, NamedTuple, Optional, Tuple

from hri_sync.timing.health import ERROR, OK, WARN, Health, text
from hri_sync.timing.vocabulary import Action, Outcome

TOLERANCE = 0.005        # s, default: a start later than this is LATE
NAME = re.compile(r'^[A-Za-z][A-Za-z0-9_]*$')
TYPE = re.compile(r'^[A-Za-z][A-Za-z0-9_]*/[A-Za-z][A-Za-z0-9_]*$')
ROS_NAME = re.compile(r'^[~/]?[A-Za-z][A-Za-z0-9_/]*$')
COMMON = {'name', 'at', 'offset', 'tolerance', 'max_late', 'outcomes',
          'winners'}
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
    command (run without a shell)."""

    name: str
    kind: str                       # Action.KINDS
    event: str                      # Action.EVENTS
    offset: float = 0.0             # s after the event
    tolerance: float = TOLERANCE
    max_late: Optional[float] = None    # s; later: not run (None: any)
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
        unknown = set(item) - COMMON - {kind}
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
        spec = dict(
            name=name, kind=kind, event=event,
            offset=_number(item, 'offset', 0.0, lambda x: True, 's'),
            tolerance=_number(item, 'tolerance', tolerance,
                              lambda x: x >= 0, '>= 0 s'),
            max_late=_number(item, 'max_late', None, lambda x: x >= 0,
                             '>= 0 s'),
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


class StartReport(NamedTuple):
    """How a firing began: ``actual`` (global), ``local`` and ``true``
    (the host's clocks) at the instant, ``status`` and ``reason``."""

    firing: Firing
    actual: float
    local: float
    true: float
    status: str
    reason: str

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
    it (returns a note on its start or None; raises ActionFailed),
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
    note = None
    if max_late is not None and late > max_late:
        error = ActionFailed('not run: %.1f ms after its scheduled time '
                             '(max_late %.1f ms)%s' % (
                                 late * 1e3, max_late * 1e3,
                                 '; ' + firing.note if firing.note else ''))
    else:
        try:
            note = execute(firing.action)
        except ActionFailed as e:
            error = e
    status, reason = judge(firing, actual, error, note or '')
    return StartReport(firing, actual, local, true, status, reason)


class ActionTally:
    """Every report's status, and each action's last report, as a
    /diagnostics status: ERROR while an action's last firing failed,
    WARN while one was late, else OK.  Thread-safe."""

    def __init__(self):
        self._lock = threading.Lock()
        self.counts: Counter = Counter()
        self.last: Dict[str, StartReport] = {}

    def record(self, report):
        """Count one StartReport."""
        with self._lock:
            self.counts[report.status] += 1
            self.last[report.firing.action.name] = report

    def health(self):
        """The Health of the actions' last firings."""
        with self._lock:
            counts, last = dict(self.counts), dict(self.last)
        values = tuple((s, text(counts.get(s, 0))) for s in Action.STATUSES)
        values += tuple(
            (name, '%s in round %d at %+.2f ms%s' % (
                r.status, r.firing.round, r.offset * 1e3,
                ': ' + r.reason if r.reason else ''))
            for name, r in sorted(last.items()))
        for status, level in ((Action.FAILED, ERROR), (Action.LATE, WARN)):
            names = sorted(n for n, r in last.items() if r.status == status)
            if names:
                return Health(level, 'last firing %s: %s' % (
                    status, ', '.join(names)), values)
        if not last:
            return Health(OK, 'no action fired yet', values)
        return Health(OK, 'last firings on time', values)
