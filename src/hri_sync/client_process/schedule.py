"""The client process module's side of a round: ``ClientSchedule``.

No ROS.  It answers a sync_time with an ACK or a NACK and turns a
capture order into a local start time, from plain values (times of the
local or global clock, always passed in).
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass
from typing import TYPE_CHECKING

from hri_sync.wire.protocol import Capture, ProtocolError


if TYPE_CHECKING:
    from hri_sync.wire.times import LocalTime
    from hri_sync.clock.model import ClockModel
    from hri_sync.clock.sync import ClockStatus
    from hri_sync.client_process.liveness import Verdict


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
    failed).  With a liveness ``Verdict``
    (``hri_sync.client_process.liveness``: is the DPM alive, its sensor
    delivering) that is not ok, it NACKs
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
            self.ignored['acked_not_a_participant'
                         if capture.round == self.acked_round
                         else 'not_a_participant'] += 1
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
