"""The control module's side of one round: ``ControlRound``.

No ROS.  It takes plain values (times of the global clock, passed in)
and returns the protocol's records (``hri_sync.wire.protocol``); the CM's
session of rounds (``session``) drives it.
"""

from __future__ import annotations

import math
from collections import Counter
from typing import Any

from hri_sync.wire.protocol import (Abort, Ack, Capture, ProtocolError,
                                    StrAftPolicy)


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
