"""The control module's session: numbered rounds, one at a time.

No ROS, no sleeping.  ``ControlSession`` is the CM's side of the protocol
as a state machine driven by events, each given the server's global time
``now``: ``start`` (a round asked for, automatically or by the
``~start_round`` service), ``on_ack``, ``on_decision``, ``poll`` (time
passes: all ACKs in or the ACK deadline, the decision or its deadline) and
``shutdown``.  Each returns a list of outputs for the shell to put on the
wire or in the log: ``SyncOrder`` (/sync_time), ``StatusUpdate``
(/round_status), ``protocol.Capture`` (/capture_data), ``Log`` and, once
per round, ``RoundEnd``; ``start`` returns ``Refused`` while a round runs.
One round is a ``protocol.ControlRound``; STR_AFT comes from its
``protocol.StrAftPolicy``, fed with each ACK's dispatch latency
(``sync_received`` minus the round's sync_time stamp, both global).
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass
from typing import Any, TYPE_CHECKING

from hri_sync.control.round import ControlRound
from hri_sync.wire.protocol import Abort, Ack, ProtocolError
from hri_sync.wire.vocabulary import RoundState
from hri_sync.wire.config import unknown

if TYPE_CHECKING:
    from hri_sync.wire.protocol import Capture, StrAftPolicy


IDLE = 'idle'
SYNCING, CAPTURING = RoundState.SYNCING, RoundState.CAPTURING
ABORTED = RoundState.ABORTED   # a RoundStatus state and a RoundEnd outcome
DECIDED, NO_DECISION, SHUTDOWN = 'decided', 'no_decision', 'shutdown'


@dataclass(frozen=True)
class SyncOrder:
    """Broadcast sync_time for ``round``, stamped ``stamp`` (global)."""

    round: int
    stamp: float


@dataclass(frozen=True)
class StatusUpdate:
    """A round's state change (the fields of hri_sync/RoundStatus).

    ``stamp`` is global; NaN when the server has no clock.
    """

    round: int
    state: str          # SYNCING, CAPTURING or ABORTED
    reason: str
    acked: list
    refused: list
    missing: list
    stamp: float


@dataclass(frozen=True)
class Log:
    """A line for the node's log; ``level`` is debug, info, warn or error."""

    level: str
    text: str


@dataclass(frozen=True)
class RoundEnd:
    """How a round ended: DECIDED, ABORTED, NO_DECISION or SHUTDOWN."""

    round: int
    outcome: str
    message: str

    @property
    def ok(self) -> bool:
        """True when the round got its decision."""
        return self.outcome == DECIDED


@dataclass(frozen=True)
class Refused:
    """``start`` refused: a round is still running, or shutting down."""

    message: str
    ok = False


def _secs(t: float) -> float:
    """A ROS time or a float as float seconds."""
    return t.to_sec() if hasattr(t, 'to_sec') else float(t)


class ControlSession:
    """The CM: rounds numbered from ``first_round``, one at a time.

    A round starts with sync_time; it closes when every client answered
    or ``ack_timeout`` s (global) after its start, into a capture order
    (every client ACKed ok, or ``min_clients`` did) or an abort naming
    the missing and refusing clients; a captured round ends with its
    decision, or ``decision_timeout`` s after its window's end without
    one.  Parameters are checked as ``ControlRound`` checks them
    (``ProtocolError``).
    """

    def __init__(self, clients: list[Any], dur: float, policy: StrAftPolicy,
                 min_clients: int | None = None, ack_timeout: float = 3.0,
                 decision_timeout: float = 5.0, first_round: int = 1) -> None:
        if not (isinstance(first_round, int) and first_round >= 1):
            raise ProtocolError('~first_round must be >= 1, got %r'
                                % (first_round,))
        ControlRound(first_round, clients, dur, policy, min_clients)
        for name, value in (('ack_timeout', ack_timeout),
                            ('decision_timeout', decision_timeout)):
            if not (isinstance(value, (int, float)) and math.isfinite(value)
                    and value > 0):
                raise ProtocolError('~%s must be > 0 s, got %r'
                                    % (name, value))
        self.clients = list(clients)
        self.dur = dur
        self.policy = policy
        self.min_clients = min_clients
        self.ack_timeout = ack_timeout
        self.decision_timeout = decision_timeout
        self.next_round = first_round
        self.phase = IDLE
        self.current: ControlRound | None = None  # in progress or last
        self.order: Capture | None = None  # its Capture, once sent
        self.deadline = math.nan   # global: ACKs, then the decision
        self.sync_stamp = math.nan
        self.decided = False
        self.ended: dict[int, RoundEnd] = {}  # recent rounds
        self.ignored: Counter[str] = Counter()  # decisions not acted on
        self.stopped = False

    @property
    def idle(self) -> bool:
        """True when no round is running (a start would be accepted)."""
        return self.phase == IDLE and not self.stopped

    @property
    def round(self) -> int:
        """The round in progress, or the last one started
        (``first_round - 1`` before any)."""
        return self.next_round - 1

    def start(self, now: float, clock_ok: bool = True,
              clock_error: str = '') -> list[Any]:
        """Start the next round at global ``now``.

        ``clock_ok`` false (the server has no clock model; ``clock_error``
        says why) aborts the round at once.
        """
        if self.stopped:
            return [Refused('the control module is shutting down')]
        if self.phase != IDLE:
            return [Refused('round %d is still running' % self.round)]
        rnd = ControlRound(self.next_round, self.clients, self.dur,
                           self.policy, self.min_clients)
        self.next_round += 1
        if not clock_ok:
            reason = ('round %d aborted: the server cannot reach its time '
                      'server: %s' % (rnd.round, clock_error))
            return [Log('error', reason),
                    self._status(rnd, ABORTED, reason, math.nan),
                    self._end(rnd.round, ABORTED, reason)]
        self.current, self.order, self.decided = rnd, None, False
        self.phase = SYNCING
        self.sync_stamp = now
        self.deadline = now + self.ack_timeout
        return [self._status(rnd, SYNCING, '', now),
                SyncOrder(rnd.round, now)]

    def on_ack(self, msg: Any) -> list[Log]:
        """A SyncAck (or anything with its fields; ``sync_received`` a ROS
        time or float seconds, global).  Returns log lines only: the round
        moves on at the next ``poll``."""
        ok = bool(msg.ok)
        rnd = self.current
        latency = (_secs(msg.sync_received) - self.sync_stamp
                   if ok and self.phase == SYNCING else math.nan)
        ack = Ack(msg.round, msg.client_id, ok, msg.reason, msg.offset,
                  msg.uncertainty, latency)
        if rnd is None:
            return [Log('warn', 'ACK from %s for round %d before any round: '
                        'ignored' % (msg.client_id, msg.round))]
        if msg.client_id not in rnd.clients:
            rnd.on_ack(ack)
            return [Log('warn', 'ACK for round %d ignored: %s (~clients)'
                        % (msg.round, unknown('client', msg.client_id,
                                              rnd.clients)))]
        if not rnd.on_ack(ack):
            return [Log('warn', 'ACK from %s for round %d ignored (round %d '
                        'open; ignored so far: %s)'
                        % (msg.client_id, msg.round, rnd.round,
                           dict(rnd.ignored)))]
        return [Log('info', 'round %d: %s %s offset %+.6f s +/- %.3f ms%s'
                    % (msg.round, msg.client_id, 'ACK' if ok else 'NACK',
                       msg.offset, msg.uncertainty * 1e3,
                       '' if ok else ' (%s)' % msg.reason))]

    def on_decision(self, round_id: int) -> list[Any]:
        """A Decision for ``round_id``; acted on at the next ``poll``."""
        current = self.current.round if self.current else None
        if self.phase == CAPTURING and round_id == current:
            self.decided = True
            return []
        if self.phase != IDLE and round_id == current:
            why = 'before_capture'
            log = Log('warn', 'decision for round %d before its capture '
                      'order: ignored' % round_id)
        elif round_id > self.round:
            why = 'future_round'
            log = Log('warn', 'decision for round %d, which has not '
                      'started (last round %d): ignored'
                      % (round_id, self.round))
        elif self.outcome(round_id) == NO_DECISION:
            why = 'after_deadline'
            log = Log('warn', 'round %d: its decision arrived after the '
                      'control module stopped waiting for it' % round_id)
        else:
            why = 'old_round'
            log = Log('debug', 'decision for round %d (ended: %s): nothing '
                      'to do' % (round_id, self.outcome(round_id)))
        self.ignored[why] += 1
        return [log]

    def poll(self, now: float) -> list[Any]:
        """Let time pass to global ``now``: close the ACKs, end the
        round."""
        rnd = self.current
        if self.phase == SYNCING and rnd is not None:
            if rnd.all_answered() or now >= self.deadline:
                return self._close(rnd, now)
        elif self.phase == CAPTURING and self.order is not None:
            round_id = self.order.round
            if self.decided:
                return [self._end(round_id, DECIDED,
                                  'round %d decided' % round_id)]
            if now >= self.deadline:
                return [Log('error', 'round %d: no decision within %.1f s '
                            'of the window end'
                            % (round_id, self.decision_timeout)),
                        self._end(round_id, NO_DECISION,
                                  'round %d captured, no decision'
                                  % round_id)]
        return []

    def shutdown(self) -> list[Any]:
        """The node stops: end the round in progress as SHUTDOWN; refuse
        further starts."""
        self.stopped = True
        if self.phase == IDLE or self.current is None:
            return []
        round_id = self.current.round
        before = 'its decision' if self.phase == CAPTURING else \
            'its capture order'
        return [Log('warn', 'round %d: shut down before %s'
                    % (round_id, before)),
                self._end(round_id, SHUTDOWN,
                          'round %d: shut down' % round_id)]

    def result(self, round_id: int) -> RoundEnd | None:
        """The RoundEnd of ``round_id``, or None while it runs (or when it
        is unknown or long past)."""
        return self.ended.get(round_id)

    def outcome(self, round_id: int) -> str:
        """How ``round_id`` ended ('unknown' while it runs or if unknown)."""
        end = self.ended.get(round_id)
        return end.outcome if end else 'unknown'

    def _close(self, rnd: ControlRound,
               now: float) -> list[Capture | StatusUpdate | Log | RoundEnd]:
        order = rnd.close(now)
        if isinstance(order, Abort):
            return [Log('error', order.reason),
                    self._status(rnd, ABORTED, order.reason, now),
                    self._end(rnd.round, ABORTED, order.reason)]
        self.order = order
        self.phase = CAPTURING
        self.deadline = order.end + self.decision_timeout
        note = ''
        if len(order.clients) < len(self.clients):
            note = ' (quorum without %s)' % ', '.join(
                c for c in self.clients if c not in order.clients)
        return [order,
                self._status(rnd, CAPTURING, note.strip(), now),
                Log('info', 'round %d: capture_data CR_T=%.6f STR_AFT=%.3f '
                    's DUR=%.3f s for %s%s'
                    % (order.round, order.cr_t, order.str_aft, order.dur,
                       ','.join(order.clients), note))]

    @staticmethod
    def _status(rnd: ControlRound, state: str, reason: str,
                now: float) -> StatusUpdate:
        return StatusUpdate(rnd.round, state, reason, rnd.acked,
                            rnd.refused, rnd.missing, now)

    def _end(self, round_id: int, outcome: str, message: str) -> RoundEnd:
        self.phase = IDLE
        end = RoundEnd(round_id, outcome, message)
        self.ended[round_id] = end
        for old in [r for r in self.ended if r <= round_id - 20]:
            del self.ended[old]
        return end


class ClientsWait:
    """What the CM waits for before round 1: every client settled.

    A client is settled once its clock_state is usable, its CPM is
    linked (connected to the CM's sync_time and sync_ack: a sync order
    sent before would be lost, and the round aborted for a missing ACK)
    and, for a client in ``dpms`` (a participant: its CPM ACKs only with
    a live DPM whose sensor delivers), its DPM's heartbeat has been heard
    and has counted a sample from its sensor; or once it reported
    ``failures`` failed clock syncs in a row (its time server is
    unreachable: waiting longer would not help, and the round lets it
    NACK with its reason).  A client that has reported nothing yet (a
    node still starting on a loaded machine) is waited for.  Feed
    ``on_state`` each clock_state: ``usable`` and the reason when not;
    ``on_dpm`` each heartbeat with its sample count; ``on_links`` the
    clients whose CPM is linked now and ``on_samples`` the time, each
    poll.  Once nothing else is waited for, links are waited for
    ``link_timeout`` s at most (a CPM reached through a relay or bridge
    never shows as linked) and samples ``sample_timeout`` s (a sensor
    that never starts: the CPM NACKs naming it).
    """

    def __init__(self, clients: list[str], failures: int = 2,
                 dpms: list[str] | tuple[str, ...] = (),
                 link_timeout: float = 10.0,
                 sample_timeout: float = 10.0) -> None:
        if failures < 1:
            raise ValueError('failures must be >= 1')
        self.clients = list(clients)
        self.failures = failures
        self.dpms = set(dpms) & set(self.clients)
        self.heard: set[str] = set()  # clients whose DPM beat was heard
        self.fed: set[str] = set()  # ... and reported samples
        self.refused: dict[str, str] = {}  # client -> why its DPM refused
        self.linked: set[str] = set()  # clients whose CPM is connected
        self.link_timeout = link_timeout
        self.sample_timeout = sample_timeout
        self.require_links = True  # False once link_timeout has passed
        self.require_samples = True  # False once sample_timeout has
        # 'links', 'samples' -> since when only those are waited for
        self._late_since: dict[str, float] = {}
        self.usable: set[str] = set()
        self.failed: Counter[str] = Counter()  # failed reports in a row
        self.reason: dict[str, str] = {}  # client -> its last reason

    def on_state(self, client: str, usable: bool, reason: str = '') -> None:
        """A clock_state of ``client`` (unknown clients are ignored)."""
        if client not in self.clients:
            return
        if usable:
            self.usable.add(client)
            self.failed[client] = 0
            self.reason[client] = ''
        else:
            self.usable.discard(client)
            self.failed[client] += 1
            self.reason[client] = reason or 'no reason given'

    def on_dpm(self, client: str, samples: int,
               refused_reason: str = '') -> None:
        """A heartbeat of ``client``'s DPM, which has received
        ``samples`` samples from its sensor (and refused the last one it
        refused for ``refused_reason``)."""
        self.heard.add(client)
        if samples > 0:
            self.fed.add(client)
        if refused_reason:
            self.refused[client] = refused_reason

    @property
    def settled(self) -> bool:
        """True once every client is settled (see the class)."""
        return not self.waiting()

    def _given_up(self, what: str, timeout: float, now: float) -> bool:
        """True once ``what`` ('links' or 'samples') has been the only
        thing waited for (with the other) for ``timeout`` s at ``now``."""
        if self.waiting(links=False, samples=False):
            self._late_since.pop(what, None)
            return False
        since = self._late_since.setdefault(what, now)
        return now - since >= timeout

    def on_links(self, clients: set[str] | frozenset[str],
                 now: float) -> list[Any]:
        """The clients whose CPM is connected both ways at ``now`` (any
        monotonic clock); returns the unlinked clients once, when links
        stop being waited for, else []."""
        self.linked = set(clients)
        if not self.require_links or \
                not self._given_up('links', self.link_timeout, now):
            return []
        self.require_links = False
        return self.unlinked()

    def on_samples(self, now: float) -> list[Any]:
        """The time (the clock of ``on_links``); returns the participants
        whose DPM has counted no sample once, when samples stop being
        waited for, else []."""
        if not self.require_samples or \
                not self._given_up('samples', self.sample_timeout, now):
            return []
        self.require_samples = False
        return self.unfed()

    def _dpm_waited(self, client: str, samples: bool) -> bool:
        return client in self.dpms and (
            client not in self.heard or samples and client not in self.fed)

    def _ready(self, client: str, links: bool, samples: bool) -> bool:
        return (not links or client in self.linked) \
            and not self._dpm_waited(client, samples)

    def unlinked(self) -> list[Any]:
        """The clients whose CPM is not linked now, in order."""
        return [c for c in self.clients if c not in self.linked]

    def unfed(self) -> list[Any]:
        """The participants whose DPM was heard but has counted no
        sample, in order."""
        return [c for c in self.clients
                if c in self.dpms and c in self.heard and c not in self.fed]

    def waiting(self, links: bool | None = None,
                samples: bool | None = None) -> list[Any]:
        """The clients not settled yet, in order; ``links`` or
        ``samples`` False: as if those were not waited for (default:
        ``require_links``, ``require_samples``)."""
        links = self.require_links if links is None else links
        samples = self.require_samples if samples is None else samples
        return [c for c in self.clients
                if (c not in self.usable and self.failed[c] < self.failures)
                or (c in self.usable and not self._ready(c, links, samples))]

    def unsynced(self) -> list[Any]:
        """The clients without a usable clock, in order."""
        return [c for c in self.clients if c not in self.usable]

    def unready(self) -> list[Any]:
        """The clients whose CPM is not linked or whose DPM (of one in
        ``dpms``) was never heard or counted no sample, in order."""
        return [c for c in self.clients
                if not self._ready(c, self.require_links,
                                   self.require_samples)]

    def describe(self, clients: list[str]) -> str:
        """'c (why it is waited for)' for ``clients``: its clock's last
        reason, no clock_state yet, its CPM not linked, no dpm_state yet
        or no sample yet."""
        def why(c: str) -> str:
            if c in self.usable:
                if self.require_links and c not in self.linked:
                    return 'its CPM not connected to sync_time and sync_ack'
                if self._dpm_waited(c, False):
                    return 'no dpm_state from its DPM yet'
                if self._dpm_waited(c, self.require_samples):
                    if c in self.refused:
                        return ('its DPM refuses its sensor\'s samples (%s)'
                                % self.refused[c])
                    return 'its DPM has received no sample from its sensor'
                return 'ready'
            return self.reason.get(c) or 'no clock_state yet'
        return ', '.join('%s (%s)' % (c, why(c)) for c in clients)
