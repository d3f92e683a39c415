"""The records a round's two ends exchange, as plain values (no ROS).

``Ack`` (a client's SyncAck), ``Capture`` (capture_data), ``Abort``, the
start-after policy (``StrAftPolicy``) and ``ProtocolError``.  The CM's
side of a round is ``hri_sync.control.round.ControlRound``; the CPM's is
``hri_sync.client_process.schedule.ClientSchedule``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any, Optional

from hri_sync.wire.times import GlobalTime


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


