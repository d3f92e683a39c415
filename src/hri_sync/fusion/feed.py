"""What the fusion is fed, live or from a recording.

The live node (``ros_fusion``) fuses on its host's clock as skeletons
arrive. A recording keeps when each message reached the recorder:
``Replay`` feeds the recorded messages to a ``Fusion`` in that order, its
clock the recorder's (through the recorder host's clock model, when it
was recorded), polling every ``poll_period`` s between them as the
node's timer does. The frames come out as the live node would have
published them had it run on the recorder's host.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Callable, Dict, Iterable, Iterator, List, Optional

import numpy as np

from hri_sync.clock.model import ClockModel
from hri_sync.fusion.pipeline import Frame, Fusion
from hri_sync.wire.times import GlobalTime, LocalTime

SKELETON, VIEW_CLOCK, HOST_CLOCK = 'skeleton', 'view_clock', 'host_clock'
VIEW_STATUS = 'view_status'
# Each view's topics (%s: the view id), as client.launch names them: the
# fusion node's ~skeleton_topic, ~clock_topic, ~status_topic and fuse_bag's
# --skeleton-topic, --clock-topic, --status-topic default to them.
VIEW_TOPICS = {SKELETON: '/%s/skeleton', VIEW_CLOCK: '/%s/clock_state',
               VIEW_STATUS: '/%s/tracker/sensor_status'}


def clock_model(state: Any) -> Optional[ClockModel]:
    """The clock model a ClockState carries, None when it says not ok.
    Raises ValueError (or TypeError) naming the field when it holds no
    usable model (a field not finite, a drift over 1 %, a time no ROS
    time can carry)."""
    if not state.ok:
        return None
    return ClockModel.from_state(state.local_ref, state.offset, state.drift,
                                 state.uncertainty)


def to_global(local: float, model: Optional[ClockModel],
              back: bool = False) -> float:
    """Global time of host time ``local`` through a host's clock model
    (None: the host clock is the global clock); ``back``: host time of
    global ``local``."""
    if model is None:
        return local
    if back:
        return float(model.to_local(GlobalTime(local)))
    return float(model.to_global(LocalTime(local)))


def stamp_uncertainty(state: Any, extra: float) -> float:
    """A view's stamps' uncertainty from its last ClockState (None: none
    came yet; not ok or no usable model: its clock model is lost, inf)
    plus ``extra``: worked out as each ClockState comes, not per
    skeleton."""
    if state is None:
        return extra
    try:
        model = clock_model(state)
    except (TypeError, ValueError):
        model = None
    return extra + (math.inf if model is None else model.uncertainty)


def add_skeleton(fusion: Fusion, view: str, msg: Any,
                 uncertainty: float) -> None:
    """A hri_sync/Skeleton of ``view`` into the fusion (what it leaves
    out, the view's health counts)."""
    fusion.add(view, msg.user_id, msg.header.stamp.to_sec(),
               np.array([(p.x, p.y, p.z) for p in msg.positions], float),
               np.array(msg.confidence, float), uncertainty)


@dataclass
class Recorded:
    """One recorded message.  ``t``: when the recorder got it (its host's
    clock, s); ``kind``: SKELETON (``data`` a hri_sync/Skeleton),
    VIEW_CLOCK (a view's ClockState), VIEW_STATUS (its sensor's
    DiagnosticStatus) or HOST_CLOCK (the recorder host's ClockState);
    ``view``: the view it belongs to."""

    t: float
    kind: str
    view: str = ''
    data: Any = None


@dataclass
class Step:
    """What the replay gave at host time ``t``: fused frames, whether a
    status report (the node's 1 Hz diagnostics) was due, and whether the
    records ended (the flush follows: the views then stall)."""

    t: float
    frames: List[Frame]
    status_due: bool
    ended: bool = False


class Replay:
    """A recording through the fusion on the recorder's clock."""

    def __init__(self, make_fusion: Callable[[Callable[[], float]], Fusion],
                 extra: float = 0.001, poll_period: float = 0.005,
                 status_period: float = 1.0) -> None:
        self.local = -math.inf          # the recorder's clock now
        self.host: Optional[ClockModel] = None  # its clock, if recorded
        self.uncertainty: Dict[str, float] = {}  # view: of its stamps
        self.bad_host_states = 0        # the host's, no usable model
        self.extra = extra
        self.poll_period = poll_period
        self.status_period = status_period
        self.next_poll = -math.inf
        self.next_status = -math.inf
        self.fusion = make_fusion(self.now)

    def now(self) -> float:
        """The fusion's clock: the recorder's, on the global clock."""
        return to_global(self.local, self.host)

    def run(self, records: Iterable[Recorded],
            flush: float = 1.0) -> Iterator[Step]:
        """Each step with frames or a status due, in time order; after the
        last record a step ``ended``, then ``flush`` s more. Raises
        ValueError on a record older than the one before it."""
        for r in records:
            if r.t < self.local:
                raise ValueError('record at %.6f s after one at %.6f s: '
                                 'not in the order recorded'
                                 % (r.t, self.local))
            yield from self._advance(r.t)
            self._apply(r)
            frames = self.fusion.poll() if r.kind == SKELETON else []
            if frames:
                yield Step(self.local, frames, False)
        if math.isfinite(self.local):
            yield Step(self.local, [], False, ended=True)
            yield from self._advance(self.local + flush)

    def _advance(self, t: float) -> Iterator[Step]:
        """Poll on the node's timer grid up to (not at) ``t``."""
        if not math.isfinite(self.local):
            self.next_poll = math.ceil(t / self.poll_period) \
                * self.poll_period
            self.next_status = t + self.status_period
        while self.next_poll < t:
            self.local = self.next_poll
            frames = self.fusion.poll()
            due = self.local >= self.next_status
            if due:
                self.next_status += self.status_period
            if frames or due:
                yield Step(self.local, frames, due)
            self.next_poll += self.poll_period
        self.local = t

    def _apply(self, r: Recorded) -> None:
        if r.kind == HOST_CLOCK:
            try:
                self.host = clock_model(r.data)
            except (TypeError, ValueError):  # the last usable one stays
                self.bad_host_states += 1
        elif r.kind == VIEW_CLOCK:
            self.uncertainty[r.view] = stamp_uncertainty(r.data, self.extra)
        elif r.kind == VIEW_STATUS:
            self.fusion.sensor_said(r.view, getattr(r.data, 'level', None),
                                    getattr(r.data, 'message', None))
        elif r.kind == SKELETON:
            add_skeleton(self.fusion, r.view, r.data,
                         self.uncertainty.get(r.view, self.extra))
        else:
            raise ValueError('unknown record kind %r' % r.kind)

