#!/usr/bin/python3
"""Checks a safety stop of the base (issue 19 item 4) from outside.

One second into DJ Rob's dance it injects ~fault:
- timeserver: chronyd killed (SIGKILL).  The robot syncs every 0.5 s, so
  its last good sync is at most one period before the kill, and its
  clock is dead ~clock_max_age s after that sync;
- odom: kobuki_sim frozen (SIGSTOP; SIGCONT at the end): no odometry
  while the robot dances;
- decision: the decision module frozen (SIGSTOP) until the robot has
  declared the decision missing, then let go (SIGCONT): whatever it
  decides then is stale.
Then it checks, by the robot's stamps and the order of what arrives (no
bound on how fast this loaded machine is):
- a hri_sync/SafetyStop on /dj_rob/safety_stop with the fault's reason,
  in the round being danced (a dead clock also refuses the winner
  gesture after the window: a second stop, same reason; a decision that
  comes after it was declared missing: decision_stale);
- its onset is the fault's: for the clock, exactly the last good sync
  (the local_ref of the last ok clock_state received before the onset,
  on the same host clock) + clock_max_age, and that sync came before the
  kill (+ one resync period); for the odometry, the robot's last odometry
  receipt + odom_max_age, after the freeze began (and not later than the freeze
  plus the odometry period and delivery); for the decision, the window
  end + decision_timeout;
- the last moving command was cleared by a check no later than the onset,
  and the zero went out after it (last_moving <= onset <= stopped);
- on the wire, until the window ends (for the decision: ever, and no
  motion after the window, no gesture): a zero command arrives after the
  last moving one, and the moving commands after the fault are at most
  one per 20 ms command period until the onset, plus DELIVERY_SLACK s
  of them in flight (a robot that went on dancing would send some 300
  more).
"""
import math
import os
import signal
import threading
import time
import unittest

import rospy
import rostest
from geometry_msgs.msg import Twist

from hri_sync.msg import ActionStart, ClockState, SafetyStop
from hri_sync.ros.node import init_checker
from hri_sync.ros.timers import wait_for
from hri_sync.ros.unique import node_pid
from hri_sync.tools.procs import descendants

PERIOD = 0.02            # s, the robot's command period (rate 50 Hz)
RESYNC = 0.5             # s, the robot's resync period
INJECT_AFTER = 1.0       # s into the dance
DELIVERY_SLACK = 0.5     # s of commands delivered late, see the docstring


class RobotSafety(unittest.TestCase):
    """A fault mid-dance stops the base."""

    @classmethod
    def setUpClass(cls):
        init_checker('robot_safety_check')
        cls.fault = rospy.get_param('~fault')
        cls.lock = threading.Lock()
        cls.cmds, cls.stops, cls.clock, cls.starts = [], [], [], []
        sub = rospy.Subscriber
        sub('/mobile_base/commands/velocity', Twist, lambda m: cls.rec(
            'cmds', (m.linear.x, m.angular.z)), queue_size=1000)
        sub('/dj_rob/safety_stop', SafetyStop, lambda m: cls.rec(
            'stops', m))
        sub('/dj_rob/clock_state', ClockState, lambda m: cls.rec('clock', m))
        sub('/dj_rob/action_start', ActionStart, lambda m: cls.rec(
            'starts', m))
        cls.injected = cls.inject()

    @classmethod
    def rec(cls, key, value):
        with cls.lock:
            getattr(cls, key).append((time.time(), value))

    @classmethod
    def inject(cls):
        """The fault, one second into the dance: its time, or None."""
        if not wait_for(lambda: cls.starts, 120.0):
            return None
        time.sleep(INJECT_AFTER)
        if cls.fault == 'decision':
            pid = [node_pid('/decision_module')]
            sig = signal.SIGSTOP
        elif cls.fault == 'timeserver':
            ts = node_pid('/time_server')
            pid = [p for p, info in descendants(ts).items()
                   if info.ppid == ts and info.name == 'chronyd']
            sig = signal.SIGKILL
        else:
            pid = [node_pid('/kobuki_sim')]
            sig = signal.SIGSTOP
        t = time.time()
        os.kill(pid[0], sig)
        rospy.loginfo('fault %s injected: signal %d to pid %d', cls.fault,
                      sig, pid[0])
        wait_for(lambda: cls.stops, 30.0)
        time.sleep(2.0)              # what follows the stop
        if sig == signal.SIGSTOP:
            os.kill(pid[0], signal.SIGCONT)
            time.sleep(4.0)          # a decision, now stale
        return t

    def stop(self):
        self.assertIsNotNone(self.injected, 'no dance started')
        with self.lock:
            stops = list(self.stops)
        self.assertTrue(stops, 'no SafetyStop')
        return stops[0]

    def test_1_reason_and_round(self):
        _, s = self.stop()
        with self.lock:
            dance = self.starts[0][1]
        rospy.loginfo('safety stop: %s in round %d: %s; onset %+.1f ms '
                      'after the fault, zero %.2f ms after the onset',
                      s.reason, s.round, s.detail,
                      (s.onset - self.injected) * 1e3,
                      (s.stopped - s.onset) * 1e3)
        expect, later = {
            'timeserver': (SafetyStop.CLOCK_DEAD, {SafetyStop.CLOCK_DEAD}),
            'odom': (SafetyStop.ODOM_STALE, set()),
            'decision': (SafetyStop.DECISION_MISSING,
                         {SafetyStop.DECISION_STALE})}[self.fault]
        self.assertEqual(s.reason, expect, s.detail)
        with self.lock:
            others = {m.reason for _, m in self.stops[1:]}
        self.assertLessEqual(others, later)
        self.assertEqual(s.round, dance.round)
        self.assertEqual(s.client_id, 'dj_rob')
        self.assertAlmostEqual(s.deadline, PERIOD)

    def test_2_onset_is_the_faults(self):
        _, s = self.stop()
        if self.fault == 'timeserver':
            limit = rospy.get_param('~clock_max_age')
            # The robot could act only on a sync it had published before
            # the onset: a burst in flight at the kill keeps its answered
            # exchanges and yields, seconds later, a sync whose local_ref
            # is from before the kill.
            with self.lock:
                refs = [m.local_ref for t, m in self.clock
                        if m.ok and t <= s.onset]
            self.assertTrue(refs, 'no ok clock_state before the onset')
            self.assertAlmostEqual(s.onset, refs[-1] + limit, places=5)
            self.assertLess(refs[-1], self.injected + RESYNC,
                            'the last good sync came after the kill')
            self.assertGreater(refs[-1], self.injected - RESYNC - 0.5,
                               'no sync in the period before the kill')
        elif self.fault == 'decision':
            with self.lock:
                end = self.starts[0][1].scheduled.to_sec() + 8.0
            self.assertAlmostEqual(s.onset, end + 5.0, places=2)
        else:
            limit = rospy.get_param('~odom_max_age')
            last_odom = s.onset - limit
            self.assertGreater(last_odom, self.injected - 1.0,
                               'the odometry stopped before the freeze')
            self.assertLess(last_odom, self.injected + 1.0)
        self.assertLessEqual(s.last_moving, s.onset)
        self.assertGreater(s.last_moving, 0.0, 'it was dancing')
        self.assertGreaterEqual(s.stopped, s.onset)

    def test_3_zero_on_the_wire(self):
        _, s = self.stop()
        with self.lock:
            end = self.starts[0][1].scheduled.to_sec() + 8.0
            cmds = [(t, c) for t, c in self.cmds
                    if t < end - 0.1 or self.fault == 'decision']
        moving = [t for t, c in cmds if c != (0.0, 0.0)]
        self.assertTrue(moving)
        if self.fault == 'decision':
            self.assertLess(moving[-1], end + 0.5, 'moved after the window')
            self.assertEqual(cmds[-1][1], (0.0, 0.0))
            return
        self.assertTrue(any(c == (0.0, 0.0) and t >= moving[-1]
                            for t, c in cmds), 'no zero after the last '
                        'moving command')
        after = [t for t in moving if t > self.injected]
        most = math.ceil((s.onset - self.injected + DELIVERY_SLACK)
                         / PERIOD)
        rospy.loginfo('%d moving commands after the fault (at most %d)',
                      len(after), most)
        self.assertLessEqual(len(after), most)


if __name__ == '__main__':
    rostest.rosrun('hri_sync', 'robot_safety', RobotSafety)
