"""What DJ Rob did in one round, as the text ``dj_rob_monitor`` prints.

No ROS: the monitor collects the round's messages and odometry samples
(receipt time, x, y, yaw) and, once the base rests, hands them here.
Angles in the text are degrees wrapped to [-180, 180).
"""
import math
from typing import NamedTuple

from hri_sync.robot.dj_rob import WINNER
from hri_sync.robot.geometry import wrap_degrees

ODOM_MAX_AGE = 2.0      # s: an older last odometry sample is no pose


class Started(NamedTuple):
    """An action's ``ActionStart``: offset by its clock, true start time."""

    offset: float
    true_time: float


def heading_deg(yaw):
    """A yaw (rad) in degrees wrapped to [-180, 180)."""
    return wrap_degrees(math.degrees(yaw))


def round_report(round_id, outcome, winner, reason, bearings, now,
                 window=None, starts=None, actions=(), odom=(),
                 rested=True):
    """The report's lines.

    ``window``: (start, duration) of the capture window (global = the
    monitor's clock), None if its order was not seen; ``starts``: action
    -> :class:`Started`; ``actions``: the actions to report, in order;
    ``odom``: (time, x, y, yaw) samples, oldest first; ``bearings``: the
    participants' (deg); ``rested``: whether the base came to rest; ``now``
    on the odometry's clock."""
    lines = ['DJ Rob, round %d' % round_id]
    if window is not None:
        start, dur = window
        starts = starts or {}
        for action in actions:
            s = starts.get(action)
            if s is None:
                lines.append('  %-5s no start reported' % action)
                continue
            lines.append('  %-5s started %+.2f ms from the scheduled start '
                         'by its clock (%+.2f ms by the host clock)'
                         % (action, s.offset * 1e3,
                            (s.true_time - start) * 1e3))
        dance = [o for o in odom if start <= o[0] <= start + dur]
        if dance:
            yaws = [heading_deg(o[3]) for o in dance]
            reach = max(math.hypot(o[1] - dance[0][1], o[2] - dance[0][2])
                        for o in dance)
            lines.append('  dance: heading between %+.1f and %+.1f deg, up '
                         'to %.2f m from the start (odometry)'
                         % (min(yaws), max(yaws), reach))
    lines.append('  decision: %s%s (%s)' % (
        outcome, ' participant %d' % winner if winner else '', reason))
    last = odom[-1] if odom else None
    if last is None or now - last[0] > ODOM_MAX_AGE:
        lines.append('  no /odom: the final heading is unknown')
        return lines
    heading = heading_deg(last[3])
    where = 'at (%.3f, %.3f) m, heading %+.1f deg' % (last[1], last[2],
                                                      heading)
    if outcome == WINNER and 1 <= winner <= len(bearings):
        b = bearings[winner - 1]
        lines.append('  gesture done%s: robot %s; participant %d at %+.1f '
                     'deg: off by %.1f deg' % (
                         '' if rested else ' (still moving)', where, winner,
                         b, abs(wrap_degrees(heading - b))))
    else:
        lines.append('  no gesture; robot %s' % where)
    return lines
