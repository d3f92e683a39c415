"""Which capture commands a DPM takes: ``CommandGate`` (no ROS).

A DPM's capture commands come from its CPM on ``<id>/capture_command``,
and the inbox admits one only under the CPM's caller id; but ROS 1 has
no authentication, and a command under that caller id for a round nobody
ordered (the fuzzer's round 4294967295, sent during a clean round) would
open a window the CPM never scheduled.  The CPM schedules a window only
on the CM's capture_data that names its client, with the window
``[CR_T + STR_AFT, + DUR)``; the DPM hears the same broadcast.  So the
gate takes a command only when the CM's order of that round names this
client with the same window, whichever of the two arrives first, within
``wait`` s of each other; a command left without one is rejected and
counted: ``unscheduled_round`` (no order of that round names this
client) or ``unscheduled_window`` (one does, with another window).
A forger now has to forge the CM's order and the CPM's command in step.

Times passed in are the DPM's local times (any one clock).
"""

from __future__ import annotations

from collections import Counter, OrderedDict
from dataclasses import dataclass
from typing import Collection

UNSCHEDULED = ('unscheduled_round', 'unscheduled_window')


@dataclass(frozen=True)
class Command:
    """A capture command: a round and its window (global, s)."""

    round: int
    start: float
    end: float


@dataclass(frozen=True)
class Rejection:
    """A command rejected: its ``reason`` key and ``why`` for a human."""

    command: Command
    reason: str
    why: str


class CommandGate:
    """Capture commands, taken only for a round the CM ordered this
    client into with the same window (within ``tolerance`` s: both ends
    compute it from capture_data, one through a ROS time's
    nanoseconds).

    ``order`` records a CM order and returns the held commands it
    confirms; ``command`` returns the command when an order confirms it,
    else holds it; ``expire`` rejects the commands held more than
    ``wait`` s, forgets older orders and returns the rejections.  At
    most ``limit`` of each are kept (a flood's oldest held commands are
    rejected, its oldest orders forgotten).
    """

    def __init__(self, client_id: str, wait: float = 5.0,
                 tolerance: float = 1e-6, limit: int = 1024) -> None:
        if not wait > 0:
            raise ValueError('order wait must be > 0 s, got %r' % (wait,))
        self.client_id = client_id
        self.wait = wait
        self.tolerance = tolerance
        self.limit = limit
        self.orders: OrderedDict[Command, float] = OrderedDict()
        self.held: list[tuple[Command, float]] = []   # oldest first
        self.counts: Counter[str] = Counter()
        self._rejected: list[Rejection] = []

    def _matches(self, a: Command, b: Command) -> bool:
        return a.round == b.round and abs(a.start - b.start) <= \
            self.tolerance and abs(a.end - b.end) <= self.tolerance

    def order(self, round_id: int, start: float, end: float,
              clients: Collection[str], local: float) -> list[Command]:
        """The CM ordered round ``round_id`` for ``clients`` at local
        time ``local``: the held commands it confirms."""
        if self.client_id not in clients:
            return []
        order = Command(round_id, start, end)
        self.orders[order] = local
        self.orders.move_to_end(order)
        while len(self.orders) > self.limit:
            self.orders.popitem(last=False)
        confirmed = [c for c, _ in self.held if self._matches(c, order)]
        self.held = [h for h in self.held if not self._matches(h[0], order)]
        return confirmed

    def command(self, round_id: int, start: float, end: float,
                local: float) -> list[Command]:
        """A capture command at local time ``local``: [it] when the CM
        ordered it, else [] (held for ``wait`` s)."""
        cmd = Command(round_id, start, end)
        if any(self._matches(cmd, o) for o in self.orders):
            return [cmd]
        self.held.append((cmd, local))
        while len(self.held) > self.limit:
            self._reject(self.held.pop(0)[0])
        return []

    def _reject(self, cmd: Command) -> None:
        """Count a command no order confirmed, and say why."""
        rounds = [o for o in self.orders if o.round == cmd.round]
        if rounds:
            reason, why = UNSCHEDULED[1], (
                'the CM ordered round %d for [%.6f, %.6f)'
                % (cmd.round, rounds[-1].start, rounds[-1].end))
        else:
            reason, why = UNSCHEDULED[0], (
                'no capture_data of the CM names %s in round %d'
                % (self.client_id, cmd.round))
        self.counts[reason] += 1
        self._rejected.append(Rejection(cmd, reason, why))

    def expire(self, local: float) -> list[Rejection]:
        """At local time ``local``: the commands rejected since the last
        call (held past ``wait`` s, or beyond ``limit``); the orders past
        ``wait`` are forgotten."""
        due = [c for c, seen in self.held if local - seen > self.wait]
        self.held = [h for h in self.held if local - h[1] <= self.wait]
        for cmd in due:
            self._reject(cmd)
        for order, seen in list(self.orders.items()):
            if local - seen > self.wait:
                del self.orders[order]
        out, self._rejected = self._rejected, []
        return out
