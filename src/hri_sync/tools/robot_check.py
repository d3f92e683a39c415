"""Did DJ Rob do what the decision asked? Checked from a recording (no ROS).

After each round's window the robot must, on a ``winner``, end facing the
winner (within a tolerance, the heading from where it stands to the
participant's place) and, on ``no_winner``, ``tie`` or ``aborted``, not
move at all. Evidence: the odometry (``nav_msgs/Odometry``) and the velocity
commands recorded, by bag time, from the window's end (or the round's
start if it never captured) until the next round began or the recording
ended. Poses are taken relative to the first recorded odometry pose, the
start pose the robot itself uses.
"""
import math
from dataclasses import dataclass, field

from hri_sync.robot.choreography import target_heading
from hri_sync.robot.geometry import (relative_pose, wrap_angle,
                                     wrap_degrees, yaw_of)
from hri_sync.wire.vocabulary import Outcome

WINNER = Outcome.WINNER
STILL_LINEAR = 0.01         # m: more is motion
STILL_ANGULAR = math.radians(1.0)
CMD_EPS = 1e-3              # m/s, rad/s: a command above this moves


def deg(a):
    """Radians to degrees in [-180, 180)."""
    return wrap_degrees(math.degrees(a))


@dataclass
class Pose:
    t: float            # bag time, s
    x: float            # m, in the start pose's frame
    y: float
    yaw: float          # rad, from the start heading


def poses(odom):
    """[Pose] of recorded Odometry (Recorded t, msg), in the frame of the
    first one."""
    out = []
    origin = None
    for r in odom:
        p = r.msg.pose.pose
        x, y, yaw = p.position.x, p.position.y, yaw_of(p.orientation)
        if not all(map(math.isfinite, (x, y, yaw))):
            continue
        if origin is None:
            origin = (x, y, yaw)
        out.append(Pose(r.t, *relative_pose(origin, x, y, yaw)))
    return out


def moving(twist):
    return abs(twist.linear.x) > CMD_EPS or abs(twist.angular.z) > CMD_EPS


@dataclass
class RobotCheck:
    """The robot's behaviour after one round's decision."""

    round: int
    expected: str               # 'face participant N' or 'stay still'
    ok: object = None           # True, False, or None: cannot tell
    outcome: str = ''
    tolerance: float = 10.0             # deg
    final_heading: float = math.nan     # deg
    target: float = math.nan            # deg
    error: float = math.nan             # deg, |final - target|
    travel: float = math.nan    # m, farthest from the pose at the window end
    turn: float = math.nan      # deg, largest heading change since then
    gesture_start: float = math.nan     # bag time of the first command
    gesture_latency: float = math.nan   # s from the decision's receipt
    problems: list = field(default_factory=list)
    note: str = ''

    @property
    def verdict(self):
        if self.ok is None:
            return 'robot: n/a (%s)' % self.note
        if self.ok:
            if self.expected.startswith('face'):
                return ('robot faced participant %s within %.1f deg '
                        '(off by %.1f deg)' % (self.expected.split()[-1],
                                               self.tolerance, self.error))
            return 'robot did not move, as it should on %s' % self.outcome
        return 'ROBOT WRONG: ' + '; '.join(self.problems)


def check_robot(n, outcome, winner, decided_t, after_t, until_t, odom,
                cmd_vel, bearings, distance=None, tolerance=10.0,
                scheduled=True):
    """Check the robot after round ``n``.

    ``decided_t``: bag time the decision was recorded; ``after_t``: bag
    time from which the robot must be done dancing (the window's end);
    ``until_t``: bag time the next round began (inf: the recording's end);
    ``odom``: [Pose] (``poses``); ``cmd_vel``: [Recorded Twist];
    ``bearings``: deg of the participants from the start heading,
    participant 1 first; ``distance``: m from the start pose (None:
    bearings only); ``scheduled``: False if the robot took no part in the
    round (then it must not move either).
    """
    gesture = outcome == WINNER and scheduled
    if gesture and not 1 <= winner <= len(bearings):
        chk = RobotCheck(n, 'face participant %d' % winner, False, outcome,
                         tolerance)
        chk.problems.append('winner %d has no bearing (bearings: %s)'
                            % (winner, bearings))
        return chk
    chk = RobotCheck(n, 'face participant %d' % winner if gesture
                     else 'stay still', None, outcome, tolerance)
    if not scheduled:
        chk.note = 'the robot took no part in this round'
    segment = [p for p in odom if after_t <= p.t < until_t]
    cmds = [r for r in cmd_vel if after_t <= r.t < until_t]
    before = [p for p in odom if p.t < after_t]
    if not segment and not before:
        chk.note = 'no odometry recorded'
        return chk
    ref = before[-1] if before else segment[0]
    path = [ref] + segment
    chk.travel = max(math.hypot(p.x - ref.x, p.y - ref.y) for p in path)
    chk.turn = max(abs(deg(wrap_angle(p.yaw - ref.yaw))) for p in path)
    last = path[-1]
    chk.final_heading = deg(last.yaw)
    start = next((r.t for r in cmds if r.t >= decided_t and moving(r.msg)),
                 math.nan)
    chk.gesture_start = start
    chk.gesture_latency = start - decided_t
    if not gesture:
        moved = [r for r in cmds if moving(r.msg)]
        if moved:
            chk.problems.append('%d velocity command(s) moved it after the '
                                'window (first %.2f s after the window end)'
                                % (len(moved), moved[0].t - after_t))
        if chk.travel > STILL_LINEAR or chk.turn > math.degrees(
                STILL_ANGULAR):
            chk.problems.append('it moved: up to %.3f m and %.1f deg'
                                % (chk.travel, chk.turn))
        chk.ok = not chk.problems
        return chk
    target = target_heading(last.x, last.y,
                            math.radians(bearings[winner - 1]), distance)
    chk.target = deg(target)
    chk.error = abs(deg(wrap_angle(last.yaw - target)))
    if math.isinf(until_t) and cmds and moving(cmds[-1].msg):
        chk.note = ('the recording ends while it still moves: the gesture '
                    'was cut off')
        return chk
    if not math.isfinite(start):
        chk.problems.append('no gesture: no velocity command after the '
                            'decision')
    if chk.error > tolerance:
        chk.problems.append('ends at %+.1f deg, participant %d at %+.1f '
                            'deg: off by %.1f deg (tolerance %.1f)'
                            % (chk.final_heading, winner, chk.target,
                               chk.error, tolerance))
    chk.ok = not chk.problems
    return chk
