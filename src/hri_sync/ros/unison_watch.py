"""Watches several robots dance (robots.launch) from outside, for the
``robots_unison`` rostests and ``bench/robots_unison.py``.

Records, per robot ``R`` (a client id and namespace): the true start of
each dance (``/R/robot/action_start``), its clock model
(``/R/clock_state``) and its odometry heading (``/R/odom``) put on the
global clock by that model; and the rounds' windows and decisions.  The
analysis is ``hri_sync.tools.unison``.
"""
import threading

import rospy
from nav_msgs.msg import Odometry

from hri_sync.msg import ActionStart, CaptureData, ClockState, Decision
from hri_sync.robot.geometry import yaw_of
from hri_sync.clock.ros_clock_state import model_from_msg
from hri_sync.ros.names import protocol_topic
from hri_sync.wire.protocol import Capture
from hri_sync.tools.unison import heading_spreads, start_skews


class RobotsWatch:
    """The record of several robots' rounds (thread-safe)."""

    def __init__(self, robots):
        self.robots = list(robots)
        self.lock = threading.Lock()
        self.captures, self.decisions, self.starts = {}, {}, {}
        self.clock = {}
        self.tracks = {r: [] for r in self.robots}
        self.unmapped = 0           # odometry before the robot's clock
        sub = rospy.Subscriber
        sub(protocol_topic('capture_data'), CaptureData, self._on_capture)
        sub(protocol_topic('decision'), Decision, self._on_decision)
        for r in self.robots:
            sub(protocol_topic('%s/robot/action_start' % r), ActionStart,
                self._on_start, r)
            sub(protocol_topic('%s/clock_state' % r), ClockState,
                self._on_clock, r)
            sub(protocol_topic('%s/odom' % r), Odometry, self._on_odom, r,
                queue_size=100)

    def _on_capture(self, msg):
        with self.lock:
            self.captures[msg.round] = Capture.from_msg(msg)

    def _on_decision(self, msg):
        with self.lock:
            self.decisions.setdefault(msg.round, msg)

    def _on_start(self, msg, robot):
        if msg.action == ActionStart.DANCE:
            with self.lock:
                self.starts.setdefault(msg.round, {})[robot] = msg

    def _on_clock(self, msg, robot):
        with self.lock:
            self.clock[robot] = msg

    def _on_odom(self, msg, robot):
        with self.lock:
            state = self.clock.get(robot)
        if state is None or not state.ok:
            with self.lock:
                self.unmapped += 1
            return
        t = model_from_msg(state).to_global(msg.header.stamp.to_sec())
        with self.lock:
            self.tracks[robot].append((t, yaw_of(msg.pose.pose.orientation)))

    def start_times(self):
        """{round: {robot: true start time}} of the dances seen."""
        with self.lock:
            return {n: {r: m.true_time.to_sec() for r, m in s.items()}
                    for n, s in self.starts.items()}

    def skews(self):
        """(skews {round: s}, missing {round: [robots]}) of the rounds
        that started (``tools.unison.start_skews``)."""
        with self.lock:
            rounds = set(self.captures)
        starts = self.start_times()
        return start_skews({n: starts.get(n, {}) for n in rounds},
                           self.robots)

    def sorted_tracks(self):
        """{robot: sorted (global time, heading)}."""
        with self.lock:
            return {r: sorted(t) for r, t in self.tracks.items()}

    def dance_spreads(self, round_id, tracks=None):
        """The robots' heading spreads (rad) every 20 ms of a round's
        window."""
        tracks = tracks or self.sorted_tracks()
        c = self.captures[round_id]
        return heading_spreads(tracks, c.start, c.end)
