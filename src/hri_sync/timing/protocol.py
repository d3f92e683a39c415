"""The timing model's message protocol as plain state machines.

No ROS.  The control module (CM) side is ``ControlRound``; the client
process module (CPM) side is ``ClientSchedule``.  Both take plain values
(times of the local or global clock, always passed in) and return plain
records; the nodes turn them into messages.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field
from typing import Any, Optional, TYPE_CHECKING

from hri_sync.timing.times import GlobalTime

if TYPE_CHECKING:
    from hri_sync.timing.times import LocalTime
    from hri_sync.timing.clock import ClockModel
    from hri_sync.timing.clock_sync import ClockStatus
    from hri_sync.timing.liveness import Verdict


class ProtocolError(ValueError):
    """A parameter or message that the protocol cannot work with."""


@dataclass
class Ack:
    """A client's SyncAck, as the CM sees it."""

    round: int
    client_id: str
    ok: bool
    reason: str = ''
    offset: float = 0.0
    uncertainty: float = 0.0
    latency: float = math.nan   # sync_time stamp to client receipt, s


@dataclass
class Capture:
    """The CM's capture_data order (times global, s)."""

    round: int
    cr_t: float
    str_aft: float
    dur: float
    clients: list

    @classmethod
    def from_msg(cls, msg: Any) -> 'Capture':
        """From a hri_sync/CaptureData, or anything with its fields (CR_T
        is ``header.stamp``, a ROS time or float seconds).  Values are not
        checked here."""
        cr_t = msg.header.stamp
        cr_t = cr_t.to_sec() if hasattr(cr_t, 'to_sec') else float(cr_t)
        return cls(msg.round, cr_t, msg.str_aft, msg.dur, list(msg.clients))

    @property
    def start(self) -> GlobalTime:
        """Global start of the window."""
        return GlobalTime(self.cr_t + self.str_aft)

    @property
    def end(self) -> GlobalTime:
        """Global end of the window (exclusive)."""
        return GlobalTime(self.start + self.dur)


@dataclass
class Abort:
    """The CM gives up on a round."""

    round: int
    reason: str
    acked: list
    refused: list
    missing: list


@dataclass
class StrAftPolicy:
    """How the CM chooses STR_AFT.

    A fixed value, or (``fixed is None``) the largest dispatch latency seen
    over the recent rounds times ``latency_factor``, plus twice the largest
    offset uncertainty, plus ``margin``, never below ``minimum``.
    """

    fixed: Optional[float] = None
    margin: float = 0.25
    latency_factor: float = 3.0
    minimum: float = 0.1
    history: int = 20
    latencies: list = field(default_factory=list)

    @classmethod
    def parse(cls, value: float | str | None,
              margin: float = 0.25) -> 'StrAftPolicy':
        """Build from the ``~str_aft`` param: a number of seconds or 'auto'."""
        if isinstance(value, str) and value.strip().lower() == 'auto':
            return cls(fixed=None, margin=margin)
        try:
            fixed = float(value)  # type: ignore[arg-type]  # None: raises
        except (TypeError, ValueError):
            raise ProtocolError("~str_aft must be a number of seconds or "
                                "'auto', got %r" % (value,))
        if not math.isfinite(fixed) or fixed <= 0:
            raise ProtocolError('~str_aft must be > 0 s, got %r' % (value,))
        return cls(fixed=fixed, margin=margin)

    def choose(self, acks: list[Any]) -> float:
        """STR_AFT for a round whose ok ACKs are ``acks``."""
        lat = [a.latency for a in acks if math.isfinite(a.latency)]
        self.latencies = (self.latencies + lat)[-self.history:]
        if self.fixed is not None:
            return self.fixed
        worst_latency = max(self.latencies, default=0.0)
        worst_unc = max((a.uncertainty for a in acks
                         if math.isfinite(a.uncertainty)), default=0.0)
        return max(self.minimum, self.latency_factor * max(worst_latency, 0)
                   + 2 * worst_unc + self.margin)


class ControlRound:
    """One round of the CM: sync_time out, ACKs in, capture_data or abort.

    ``clients`` must all ACK ok, unless ``min_clients`` allows a quorum.
    """

    def __init__(self, round_id: int, clients: list[Any], dur: float | str,
                 str_aft_policy: StrAftPolicy,
                 min_clients: int | None = None) -> None:
        if not clients:
            raise ProtocolError('~clients is empty: name at least one client')
        if len(set(clients)) != len(clients):
            raise ProtocolError('~clients lists a client twice: %s'
                                % ','.join(clients))
        if not (isinstance(dur, (int, float)) and math.isfinite(dur)
                and dur > 0):
            raise ProtocolError('~dur must be > 0 s, got %r' % (dur,))
        self.min_clients = len(clients) if min_clients is None else min_clients
        if not 1 <= self.min_clients <= len(clients):
            raise ProtocolError('~min_clients must be within 1..%d, got %r'
                                % (len(clients), min_clients))
        self.round = round_id
        self.clients = list(clients)
        self.dur = float(dur)
        self.policy = str_aft_policy
        self.acks: dict[str, Ack] = {}
        self.ignored: Counter[str] = Counter()
        self.done = False

    def on_ack(self, ack: Ack) -> bool:
        """Record an ACK.  Returns False (and counts why) if it is ignored."""
        if ack.round != self.round:
            self.ignored['old_round' if ack.round < self.round
                         else 'future_round'] += 1
            return False
        if ack.client_id not in self.clients:
            self.ignored['unknown_client'] += 1
            return False
        if ack.client_id in self.acks:
            self.ignored['duplicate_ack'] += 1
            return False
        if self.done:
            self.ignored['after_close'] += 1
            return False
        self.acks[ack.client_id] = ack
        return True

    @property
    def acked(self) -> list[Any]:
        """Clients that ACKed ok, in ``clients`` order."""
        return [c for c in self.clients if c in self.acks and self.acks[c].ok]

    @property
    def refused(self) -> list[Any]:
        """Clients that answered ok=false."""
        return [c for c in self.clients
                if c in self.acks and not self.acks[c].ok]

    @property
    def missing(self) -> list[Any]:
        """Clients that have not answered."""
        return [c for c in self.clients if c not in self.acks]

    def all_answered(self) -> bool:
        """True when every client answered (ok or not)."""
        return not self.missing

    def close(self, now: float) -> Capture | Abort:
        """Decide the round at ``now`` (global): a Capture or an Abort.

        Called when every client answered, or at the ACK timeout.
        """
        self.done = True
        acked = self.acked
        if len(acked) >= self.min_clients:
            str_aft = self.policy.choose([self.acks[c] for c in acked])
            return Capture(self.round, now, str_aft, self.dur, acked)
        parts = []
        for c in self.refused:
            parts.append('%s refused (%s)' % (c, self.acks[c].reason or
                                              'no reason given'))
        if self.missing:
            parts.append('no ACK from %s' % ', '.join(self.missing))
        reason = ('round %d aborted: %d of %d clients synced, %d needed: %s'
                  % (self.round, len(acked), len(self.clients),
                     self.min_clients, '; '.join(parts)))
        return Abort(self.round, reason, acked, self.refused, self.missing)


@dataclass
class SyncReply:
    """The CPM's answer to sync_time: the fields of hri_sync/SyncAck.

    Times are global; without a clock model the numbers are NaN.
    """

    round: int
    client_id: str
    ok: bool
    reason: str
    offset: float          # global minus local at ``stamp``, s
    uncertainty: float     # bound on the offset's error at ``stamp``, s
    drift: float
    sync_received: float   # when sync_time arrived
    stamp: float           # when the answer was made


@dataclass
class Scheduled:
    """A capture the CPM accepted: the window in global and local time."""

    round: int
    start: float
    end: float
    local_start: float
    lead: float        # how long before the start the order arrived, s


@dataclass
class Late:
    """A capture order that arrived after its window had started."""

    round: int
    start: float
    end: float
    lateness: float    # how far past the start it arrived, s
    reason: str


class ClientSchedule:
    """The CPM's side of the protocol: ACK or NACK, then capture orders.

    ``on_sync`` answers a sync_time from the clock's status after a fresh
    measurement: NACK without a clock model (the measurement's error),
    NACK when the model's uncertainty now exceeds ``max_uncertainty``
    (also in holdover, when the time server stopped answering and the
    bound grows with the time since the last good sync), else ACK (with
    the holdover's age and cause as the reason when the measurement
    failed).  With a liveness ``Verdict`` (``hri_sync.timing.liveness``:
    is the DPM alive, its sensor delivering) that is not ok, it NACKs
    with the verdict's reason (after the clock's, if both fail).
    ``on_capture`` turns the capture order of the round it ACKed into a
    Scheduled window or Late.
    """

    def __init__(self, client_id: str,
                 max_uncertainty: float = math.inf) -> None:
        if not max_uncertainty > 0:
            raise ProtocolError('~max_uncertainty must be > 0 s, got %r'
                                % (max_uncertainty,))
        self.client_id = client_id
        self.max_uncertainty = max_uncertainty
        self.acked_round: int | None = None
        self.ignored: Counter[str] = Counter()

    def on_sync(self, round_id: int, received: LocalTime, now: LocalTime,
                status: ClockStatus,
                alive: Verdict | None = None) -> SyncReply:
        """Answer sync_time of ``round_id``: a SyncReply.

        ``received`` and ``now`` are local times (sync_time's arrival, the
        answer); ``status`` is the clock's ClockStatus (``model``,
        ``error``) after the measurement the sync_time triggered;
        ``alive`` the liveness Verdict of the DPM behind this CPM (None:
        none to check).
        """
        model = status.model
        ok, reason = True, ''
        if not model.ready:
            ok, reason = False, status.error or 'no clock model yet'
        else:
            uncertainty = model.uncertainty_at(now)
            if uncertainty > self.max_uncertainty:
                ok = False
                reason = ('offset uncertainty %.2f ms exceeds '
                          '~max_uncertainty %.2f ms'
                          % (uncertainty * 1e3, self.max_uncertainty * 1e3))
                if status.error:
                    reason += ('; no good sync for %.1f s: %s'
                               % (now - model.local_ref, status.error))
            else:
                reason = status.reason(now)
        if alive is not None and not alive.ok:
            reason = alive.reason if ok else '%s; %s' % (reason,
                                                         alive.reason)
            ok = False
        self.acked_round = round_id if ok else None
        if not model.ready:
            return SyncReply(round_id, self.client_id, ok, reason, math.nan,
                             math.nan, math.nan, math.nan, math.nan)
        return SyncReply(round_id, self.client_id, ok, reason,
                         model.offset_at(now), model.uncertainty_at(now),
                         model.drift, model.to_global(received),
                         model.to_global(now))

    def on_capture(self, capture: Capture, now_global: float,
                   clock: ClockModel) -> Scheduled | Late | None:
        """Return Scheduled, Late, or None (ignored and counted).

        ``clock`` converts global to local time (``to_local``).
        """
        if self.client_id not in capture.clients:
            self.ignored['not_a_participant'] += 1
            return None
        if self.acked_round is None or capture.round != self.acked_round:
            self.ignored['unacked_round'] += 1
            return None
        if not (math.isfinite(capture.cr_t) and math.isfinite(capture.str_aft)
                and math.isfinite(capture.dur) and capture.dur > 0
                and capture.str_aft >= 0):
            self.ignored['malformed'] += 1
            return None
        self.acked_round = None  # one capture per ACK
        lead = capture.start - now_global
        if lead <= 0:
            return Late(capture.round, capture.start, capture.end, -lead,
                        'capture_data for round %d arrived %.1f ms after the '
                        'window start; not capturing out of step'
                        % (capture.round, -lead * 1e3))
        return Scheduled(capture.round, capture.start, capture.end,
                         clock.to_local(capture.start), lead)
