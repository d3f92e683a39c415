"""Each view's health as the fusion sees it.

A view is ``stalled`` when no skeleton came for ``stall_after`` s (the
fusion stops waiting for it), ``not_tracking`` instead when its sensor's
own status (a tracker's ``sensor_status``, at most ``sensor_fresh`` s
old) says it tracks no one (a person out of its view or range: nothing
to send, not a fault of the view), ``frozen`` when its skeletons keep
coming but only repeat the one before (joint for joint the same: no new
measurement: a driver re-sending its last skeleton) for as long;
``repeated`` counts such skeletons in the last ``window`` s. Its clock is
``lost`` when its samples' stamp uncertainty is over ``max_uncertainty``
s (they are left out); ``bad_stamps`` counts skeletons left out in the
last ``window`` s for a stamp ahead of the fusion's clock or too old;
``nan_joints``, ``zero_joints`` and ``far_joints`` count skeletons with
NaN joints, joints at the sensor's origin (a Kinect SDK's "not tracked")
or farther than a sensor sees, in the last ``window`` s (those joints are
left out); ``wrong_pose`` is set by the calibration check (the view is
down-weighted), and ``arms_exchanged`` counts the instants its tracker's
left and right arms were exchanged back (hri_sync.fusion.arms),
``turned_back`` those its tracker took the body's back for its front,
``turned_to_hands`` those its body was turned to face where the hands
reach, ``turned_to_head`` where the head leads (hri_sync.fusion.facing),
``beyond_range`` its skeletons of someone farther than the sensor tracks
(down-weighted), ``out_of_image`` its joints left out where the fused
body stands outside its image, ``out_of_reach`` its hands left out that
no fused arm reaches (hri_sync.fusion.reach). The view's pipeline latency
(arrival minus capture) is kept to know how long to wait for it.

The fusion is ``deaf`` while it hears from no view for over ``deaf_after``
s: no new skeleton and no sensor status (its node starved of CPU, or
the link to every view down; a tracker that tracks no one and says so is
heard). A person it could not have seen then is not counted as gone for
that time (hri_sync.fusion.associate).
"""

from __future__ import annotations

import collections
import math
import statistics
from dataclasses import dataclass, field
from typing import Deque, Dict, List, Tuple


# The side rules' counts as a view's status names them (status key:
# ViewHealth counter): instants the view was put right
# (hri_sync.fusion.arms, hri_sync.fusion.facing).
RULES = {'arms exchanged back': 'arms_exchanged',
         'turned back': 'turned_back',
         'turned to the hands': 'turned_to_hands',
         'turned to the head': 'turned_to_head'}
# What a view's skeletons may be noted for (counted over ``window`` s):
# the fault each is reported as, and how.
NOTED = {
    'repeated': ('repeated', 'skeletons repeated the one before'),
    'future_stamp': ('bad_stamps', "stamped ahead of the fusion's clock"),
    'stale_stamp': ('bad_stamps', 'stamped too long ago'),
    'nan_joints': ('nan_joints', 'skeletons with NaN joints'),
    'zero_joints': ('zero_joints', "skeletons with joints at the sensor's "
                    'origin (not tracked)'),
    'far_joints': ('far_joints', 'skeletons with joints farther from the '
                   'sensor than it sees'),
}


@dataclass
class HealthParams:
    """Fault thresholds."""

    stall_after: float = 0.5        # s without a skeleton
    sensor_fresh: float = 3.0       # s its sensor's status is believed
    max_uncertainty: float = 0.02   # s
    window: float = 5.0             # s
    deaf_after: float = 1.5         # s hearing from no view


@dataclass
class ViewHealth:
    """What the fusion knows of one view."""

    params: HealthParams
    arrivals: int = 0
    last_arrival: float = -math.inf
    last_new: float = -math.inf     # arrival of its last new skeleton
    last_uncertainty: float = 0.0
    latencies: Deque[float] = field(
        default_factory=lambda: collections.deque(maxlen=100))
    stamps: Deque[float] = field(
        default_factory=lambda: collections.deque(maxlen=30))
    noted: Dict[str, Deque[float]] = field(      # NOTED: arrival times
        default_factory=lambda: {k: collections.deque() for k in NOTED})
    wrong_pose: bool = False
    arms_exchanged: int = 0         # instants its arms were put right
    turned_back: int = 0            # instants its body was turned back
    turned_to_hands: int = 0        # instants it was turned to the hands
    turned_to_head: int = 0         # ... to the side the head leads to
    beyond_range: int = 0           # its skeletons of someone too far
    out_of_image: int = 0           # its joints outside its image
    out_of_reach: int = 0           # its hands no fused arm reaches
    rejected: Dict[str, int] = field(default_factory=dict)
    # its sensor's last status: (received at, message)
    sensor: Tuple[float, str] = (-math.inf, '')
    _latency: float = 0.0
    _late: float = 0.0
    _period: float = 0.0

    def arrived(self, now: float, stamp: float, uncertainty: float,
                noted: Tuple[str, ...] = ()) -> None:
        """A skeleton captured at ``stamp`` arrived at ``now``; ``noted``:
        what it is noted for (NOTED keys; ``repeated``: it repeats the
        one before)."""
        self.arrivals += 1
        self.last_arrival = now
        for event in noted:
            self.note(event, now)
        if 'repeated' not in noted:
            self.last_new = now
        self.last_uncertainty = uncertainty
        self.latencies.append(now - stamp)
        if not self.stamps or stamp > self.stamps[-1]:
            self.stamps.append(stamp)
        ordered = sorted(self.latencies)
        self._latency = ordered[int(0.95 * (len(ordered) - 1))]
        self._late = ordered[int(0.99 * (len(ordered) - 1))]
        if len(self.stamps) > 1:
            s = list(self.stamps)
            self._period = statistics.median(b - a for a, b in zip(s, s[1:]))

    def note(self, event: str, now: float) -> None:
        """Note a skeleton for ``event`` (a NOTED key) at ``now``."""
        self.noted[event].append(now)

    def reject(self, reason: str) -> None:
        """Count a skeleton left out."""
        self.rejected[reason] = self.rejected.get(reason, 0) + 1

    def latency(self) -> float:
        """p95 of arrival minus capture (s), 0 before any."""
        return self._latency

    def late(self) -> float:
        """p99 of arrival minus capture (s), 0 before any: how long
        after its capture a frame is waited for."""
        return self._late

    def period(self) -> float:
        """Median interval between its stamps (s), 0 before two."""
        return self._period

    def tracks_no_one(self, now: float) -> bool:
        """Its sensor said lately that it tracks no one."""
        at, message = self.sensor
        return now - at <= self.params.sensor_fresh \
            and message.startswith('not tracking')

    def stalled(self, now: float) -> bool:
        """No new skeleton for stall_after s (or none yet)."""
        return now - self.last_new > self.params.stall_after

    def clock_lost(self) -> bool:
        """Its stamps are too uncertain to fuse."""
        return self.last_uncertainty > self.params.max_uncertainty

    def faults(self, now: float) -> List[Tuple[str, str]]:
        """(fault, detail) of the view now; [] when healthy."""
        for times in self.noted.values():
            while times and now - times[0] > self.params.window:
                times.popleft()
        out = []
        if self.stalled(now) and self.tracks_no_one(now):
            out.append(('not_tracking', 'its sensor: %s' % self.sensor[1]))
        elif self.arrivals == 0:
            out.append(('no_data', 'no skeleton yet'))
        elif not self.stalled(now):
            pass
        elif now - self.last_arrival <= self.params.stall_after:
            out.append(('frozen', 'its skeletons repeat one of %.1f s ago'
                        % (now - self.last_new)))
        else:
            out.append(('stalled', 'no skeleton for %.1f s'
                        % (now - self.last_arrival)))
        if self.clock_lost():
            out.append(('clock_lost', 'stamp uncertainty %.1f ms > %.1f ms'
                        % (self.last_uncertainty * 1e3,
                           self.params.max_uncertainty * 1e3)))
        counts: Dict[str, List[str]] = {}
        for event, (fault, what) in NOTED.items():
            if self.noted[event] and not (event == 'repeated'
                                          and self.stalled(now)):
                counts.setdefault(fault, []).append(
                    '%d %s' % (len(self.noted[event]), what))
        out += [(fault, '%s in %.0f s' % (', '.join(what),
                                          self.params.window))
                for fault, what in counts.items()]
        if self.wrong_pose:
            out.append(('wrong_pose', 'its pose disagrees with the other '
                        'views: down-weighted'))
        return out


class Deafness:
    """When the fusion heard from no view (clock time spans)."""

    def __init__(self, after: float, keep: int = 100) -> None:
        self.after = after
        self.last = -math.inf
        self.spans: Deque[Tuple[float, float]] = collections.deque(
            maxlen=keep)

    def heard(self, now: float) -> None:
        """A view was heard from at ``now``."""
        if math.isfinite(self.last) and now - self.last > self.after:
            self.spans.append((self.last, now))
        self.last = max(self.last, now)

    def within(self, start: float, end: float) -> float:
        """Seconds of [``start``, ``end``] the fusion was deaf (the
        silence it is in at ``end`` included once over ``after``; 0 before
        it heard anything)."""
        spans = list(self.spans)
        if math.isfinite(self.last) and end - self.last > self.after:
            spans.append((self.last, end))
        return sum(max(0.0, min(b, end) - max(a, start)) for a, b in spans)
