"""The control module's calibration window: nobody moves, no winner.

No ROS, no sleeping.  Before its first round the CM orders one window of
``dur`` s on ``calibration/capture_data`` (round ``CALIBRATION_ROUND``,
``lead`` s after the order: time to say "stand still") for the
participants; their DPMs measure each sensor's noise floor in it
(``hri_sync.data_process.noise_floor.Calibration``), the simulated sensors
hold still, and the decision module answers on ``calibration/decision``
with ``no_winner``.  It is not a round: no sync_time, no ACK, nothing on
the rounds' topics, so robots and actions do nothing in it.  The CM waits
for that answer, at most ``decision_timeout`` s after the window's end,
before round 1.
"""

from __future__ import annotations

import math
from typing import Any

from hri_sync.control.session import Log
from hri_sync.wire.protocol import Capture, ProtocolError
from hri_sync.wire.vocabulary import CALIBRATION_ROUND

STILL_MARGIN = 0.2     # s a simulated person stands still before and after
OWN_CLOCK = 0.5        # s: a clock model that puts an order's receipt
#                        farther from its sending is not this host's


class CalibrationRun:
    """One calibration window, as the events of ``ControlSession``:
    ``start(now)`` (global) returns the order (a ``Capture``) and a log
    line, ``on_decision`` the DM's answer, ``poll(now)`` log lines once it
    is over (``done``): answered, or past its deadline without."""

    def __init__(self, clients: list[str], dur: float, lead: float,
                 decision_timeout: float) -> None:
        for name, value, low in (('calibration', dur, 0.0),
                                 ('calibration_lead', lead, None),
                                 ('decision_timeout', decision_timeout, 0.0)):
            ok = isinstance(value, (int, float)) and math.isfinite(value) \
                and (value > low if low is not None else value >= 0)
            if not ok:
                raise ProtocolError('~%s must be %s s, got %r' % (
                    name, '>= 0' if low is None else '> 0', value))
        if not clients:
            raise ProtocolError('a calibration window needs participants')
        self.clients = list(clients)
        self.dur = float(dur)
        self.lead = float(lead)
        self.decision_timeout = float(decision_timeout)
        self.order: Capture | None = None
        self.decided = False
        self.done = False

    def start(self, now: float) -> list[Any]:
        """The order at global ``now``, and what to tell the people."""
        self.order = Capture(CALIBRATION_ROUND, now, self.lead, self.dur,
                             self.clients)
        return [self.order, Log(
            'warn', 'calibration: everybody stand still for %.1f s from '
            'global %.3f (in %.1f s): %s measure their sensors\' noise'
            % (self.dur, self.order.start, self.lead,
               ', '.join(self.clients)))]

    def on_decision(self, round_id: int) -> list[Any]:
        """The decision module's answer on calibration/decision."""
        if self.order is None or round_id != CALIBRATION_ROUND or self.done:
            return [Log('debug', 'calibration decision for round %d: '
                        'nothing to do' % round_id)]
        self.decided = True
        return []

    def poll(self, now: float) -> list[Any]:
        """Time passes to global ``now``: the log line that ends it."""
        if self.done or self.order is None:
            return []
        if self.decided:
            self.done = True
            return [Log('info', 'calibration done: the decision module '
                        'has every participant\'s result or its deadline '
                        'passed')]
        if now >= self.order.end + self.decision_timeout:
            self.done = True
            return [Log('error', 'calibration: no answer from the decision '
                        'module within %.1f s of the window\'s end; going '
                        'on to round 1' % self.decision_timeout)]
        return []


def host_window(order: Capture, now: float, clock: Any = None,
                margin: float = STILL_MARGIN) -> tuple[float, float]:
    """The calibration window of ``order`` on this host's clock, widened by
    ``margin`` s on either side, for a simulated sensor to stand still in
    (a frame stamped a little off the window's edges is still, and a
    switch to a still recording falls outside it).  ``now``: this host's
    clock at the order's receipt.  ``clock``: a clock model (local ->
    global, ``to_global``/``to_local``) of the client, used when it is this
    host's clock (it puts the receipt within ``OWN_CLOCK`` s of the order's
    sending); else (a CPM under libfaketime beside a sensor on the true
    clock, or none) the window starts STR_AFT after the receipt."""
    if clock is not None and abs(clock.to_global(now) - order.cr_t) \
            < OWN_CLOCK:
        start = clock.to_local(order.start)
    else:
        start = now + order.str_aft
    return start - margin, start + order.dur + margin
