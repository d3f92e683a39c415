#!/usr/bin/python3
"""Checks one DJ Rob round (issue 4) from outside the robot and the music.

Publishes the participants' constant samples (~a_value, ~b_value) so the
expected participant wins, records what goes on the wire with this
process's (unfaked) clock, and after the round checks:
- the decision of each of ~rounds rounds is ~expect (participant1,
  participant2 or no_winner);
- in every round the dance and the music are scheduled exactly at
  CR_T + STR_AFT, and their starts (their own raw true-clock readings) and
  the first dance command's arrival fall near it in true time (the time
  server serves this host's clock, so global = true).  The bound,
  START_SANITY, catches a wrong schedule or clock (an error of the clients'
  fake offsets, seconds) but not load: how close the starts come (the
  issue's 10 ms) is measured by bench/dj_rob_start.py, not asserted here;
- the music's beats come at CR_T+STR_AFT + k * 0.5 s (120 BPM);
- after the last round, for a winner: the robot's final odometry heading
  points at the winner's bearing within 10 degrees, LEDs and sound were
  used; for no_winner: no motion, LED or sound after the window;
- the commands and the odometry stay within the Kobuki limits over the
  whole round, every stop ends with an explicit zero, the base never had
  to clamp or refuse a command, and no moving command was left without a
  successor for the base's command timeout.  The base's own counters of
  slewed steps and timeouts judge commands by when kobuki_sim (a normal
  priority process) got to them, so load moves them: a single command
  80 ms late costs about 5 slewed steps, while a plan 20 % over the
  acceleration limit slews about 30 % of its steps.  They are logged;
  slewing is asserted below ACCEL_LIMITED_SHARE of the commands, and the
  commanded accelerations themselves are checked on the command stream;
- no_winner round: decisions with a winner out of range, for an unknown
  round or with an unknown outcome are logged (rejected by the robot's
  inbox or its own checks) and ignored.
"""
import math
import os
import threading
import time
import unittest

import message_filters
import rospy
import rostest
import rostopic
from diagnostic_msgs.msg import DiagnosticArray
from geometry_msgs.msg import Twist
from nav_msgs.msg import Odometry
from rosgraph_msgs.msg import Log

from constant_samples import publish_constant_samples
from hri_sync.msg import (ActionStart, Beat, CaptureData, Decision, Led,
                          Sound)
from hri_sync.robot.geometry import wrap_degrees, yaw_of
from hri_sync.robot.kobuki import Limits
from hri_sync.ros.node import init_checker
from hri_sync.wire.protocol import Capture
from hri_sync.clock.truth import realtime

LIMITS = Limits()            # the Kobuki's, as dj_rob.launch sets them
START_SANITY = 0.25          # s, see the docstring
ACCEL_LIMITED_SHARE = 0.10   # of the base's commands, see the docstring
CMD_TIMEOUT = 0.6            # s, kobuki_sim's ~cmd_timeout
HEADING_TOLERANCE = 10.0     # deg


class DjRobRound(unittest.TestCase):
    """One round, observed end to end."""

    @classmethod
    def setUpClass(cls):
        # Observe arrivals promptly on a busy machine: rospy's threads
        # inherit this (below the robot's and the music's priority 10).
        with realtime(5) as rt:
            pass
        cls.realtime = rt.ok
        if rt.ok:
            os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(5))
        init_checker('dj_rob_check')
        cls.expect = rospy.get_param('~expect')
        cls.rounds = int(rospy.get_param('~rounds', 1))
        cls.bearings = rospy.get_param('~participant_bearings')
        cls.lock = threading.Lock()
        cls.cmds, cls.odom, cls.starts, cls.leds, cls.sounds = \
            [], [], [], [], []
        cls.captures, cls.decisions = {}, {}
        cls.capture = None
        cls.bad_sent = None             # when we sent bad decisions
        cls.diag = {}
        sub = rospy.Subscriber
        observers = [sub(
            '/mobile_base/commands/velocity', Twist, cls.rec,
            ('cmds', lambda m: (m.linear.x, m.angular.z)), tcp_nodelay=True,
            queue_size=1000)]
        sub('/odom', Odometry, cls.rec, ('odom', lambda m: (
            m.header.stamp.to_sec(), m.pose.pose.position.x,
            m.pose.pose.position.y, yaw_of(m.pose.pose.orientation),
            m.twist.twist.linear.x, m.twist.twist.angular.z)),
            queue_size=1000)
        observers += [sub(topic, ActionStart, cls.rec, ('starts', lambda m: m))
                      for topic in ('/dj_rob/action_start',
                                    '/music/action_start')]
        for topic in ('/mobile_base/commands/led1',
                      '/mobile_base/commands/led2'):
            sub(topic, Led, cls.rec, ('leds', lambda m: m.value))
        sub('/mobile_base/commands/sound', Sound, cls.rec,
            ('sounds', lambda m: m.value))
        cls.beats, cls.sim_leds = [], []
        sub('/music/beat', Beat, cls.rec, ('beats', lambda m: m))
        # The ROS tools that need a header.stamp: rostopic delay's
        # measure and a message_filters cache, on the beats.
        cls.beat_delay = rostopic.ROSTopicDelay(1000)
        sub('/music/beat', Beat, cls.beat_delay.callback_delay)
        cls.beat_cache = message_filters.Cache(
            message_filters.Subscriber('/music/beat', Beat), 1000)
        sub('/kobuki_sim/led1', Led, cls.rec, ('sim_leds', lambda m: m.value))
        observers += [sub('/capture_data', CaptureData, cls.on_capture),
                      sub('/decision', Decision, cls.on_decision)]
        sub('/diagnostics', DiagnosticArray, cls.on_diag)
        cls.errors = []
        sub('/rosout', Log, lambda m: cls.errors.append(m.msg)
            if m.name == '/dj_rob' and m.level >= Log.WARN else None,
            queue_size=100)
        publish_constant_samples({c: float(rospy.get_param(
            '~%s_value' % c)) for c in ('a', 'b')}, observers=observers)
        cls.wait_round()

    @classmethod
    def rec(cls, msg, args):
        key, conv = args
        with cls.lock:
            getattr(cls, key).append((time.time(), conv(msg)))

    @classmethod
    def on_capture(cls, msg):
        cls.captures[msg.round] = msg
        cls.capture = msg                 # the last round's

    @classmethod
    def on_decision(cls, msg):
        if cls.bad_sent is None and msg.round not in cls.decisions:
            cls.decisions[msg.round] = (time.time(), msg)   # the DM's

    @classmethod
    def on_diag(cls, msg):
        for s in msg.status:
            if s.hardware_id == 'kobuki_sim':
                cls.diag = {kv.key: kv.value for kv in s.values}

    @classmethod
    def wait_round(cls):
        deadline = time.time() + 60.0 + 30.0 * cls.rounds
        while len(cls.decisions) < cls.rounds and time.time() < deadline:
            time.sleep(0.1)
        if len(cls.decisions) < cls.rounds:
            return
        # The gesture takes about 6 s; wait until the base rests for 2 s.
        end = time.time() + 20.0
        while time.time() < end:
            time.sleep(0.5)
            with cls.lock:
                recent = [o for t, o in cls.odom if t > time.time() - 2.0]
                moving = any(abs(o[4]) > 1e-6 or abs(o[5]) > 1e-6
                             for o in recent)
                last_cmd = cls.cmds[-1][0] if cls.cmds else 0.0
            if recent and not moving and time.time() - last_cmd > 2.0:
                break
        time.sleep(1.5)                    # one more diagnostics period
        if cls.expect == 'no_winner':
            cls.send_bad_decisions()

    @classmethod
    def send_bad_decisions(cls):
        """Decisions the robot must log and ignore: a winner out of
        range, an unknown round, an unknown outcome, sent under the DM's
        caller id so that their content is judged (a wrong sender is
        inbox_sender.test's: rospy shares one connection per topic and
        node, so this node can publish /decision under one id only)."""
        forged = rospy.Publisher('/decision', Decision, queue_size=10,
                                 headers={'callerid': '/decision_module'})
        deadline = time.time() + 5.0
        while forged.get_num_connections() < 1 and time.time() < deadline:
            time.sleep(0.05)
        time.sleep(1.0)                   # every subscriber connected
        cls.bad_sent = time.time()
        n = cls.capture.round if cls.capture else 1
        clients = dict(clients=['a', 'b'], scores=[1.0, 2.0])
        for d in (Decision(round=n, outcome=Decision.WINNER, winner=7,
                           **clients),
                  Decision(round=n + 1000, outcome=Decision.WINNER, winner=1,
                           **clients),
                  Decision(round=n, outcome='bogus', winner=1, **clients)):
            forged.publish(d)
            time.sleep(0.2)
        time.sleep(2.0)

    def window(self):
        self.assertIsNotNone(self.capture, 'no capture_data seen')
        c = Capture.from_msg(self.capture)
        return c.start, c.end

    def test_1_decision(self):
        self.assertEqual(sorted(self.decisions),
                         list(range(1, self.rounds + 1)),
                         'decisions of rounds 1..%d expected' % self.rounds)
        for n, (_, d) in sorted(self.decisions.items()):
            self.assertIn('dj_rob', self.captures[n].clients)
            self.assertIn('music', self.captures[n].clients)
            if self.expect == 'no_winner':
                self.assertEqual(d.outcome, Decision.NO_WINNER, d.reason)
            else:
                self.assertEqual(d.outcome, Decision.WINNER, d.reason)
                self.assertEqual(d.winner, int(self.expect[-1]), d.reason)

    def test_2_starts_on_time(self):
        self.assertEqual(len(self.captures), self.rounds)
        for n, c in sorted(self.captures.items()):
            start = Capture.from_msg(c).start
            # round 1: anything in the 2 s before counts as too early;
            # later rounds: the previous gesture may brake until shortly
            # before the window
            since = start - (2.0 if n == 1 else 0.1)
            with self.lock:
                cmds = [(t, v) for t, v in self.cmds if t > since]
                starts = {m.action: m for _, m in self.starts
                          if m.round == n}
            self.assertTrue(cmds, 'round %d: no velocity command' % n)
            first = cmds[0][0] - start
            rospy.loginfo('round %d: first dance command received %+.2f ms '
                          'from the scheduled start (true time)', n,
                          first * 1e3)
            self.assertLess(abs(first), START_SANITY, 'round %d' % n)
            for action in (ActionStart.DANCE, ActionStart.MUSIC):
                self.assertIn(action, starts, 'round %d: no %s action_start'
                              % (n, action))
                m = starts[action]
                self.assertAlmostEqual(m.scheduled.to_sec(), start, places=6)
                true_offset = m.true_time.to_sec() - start
                rospy.loginfo('round %d: %s started %+.2f ms from the '
                              'schedule in true time (%+.2f ms by its own '
                              'clock)', n, action, true_offset * 1e3,
                              m.offset * 1e3)
                self.assertLess(abs(true_offset), START_SANITY,
                                'round %d %s' % (n, action))
                self.assertLess(abs(m.offset), START_SANITY,
                                'round %d %s' % (n, action))
                self.assertAlmostEqual(
                    m.header.stamp.to_sec() - m.scheduled.to_sec(),
                    m.offset, places=6, msg='round %d %s: header.stamp is '
                    'the actual start' % (n, action))

    def test_2b_beats(self):
        for n, c in sorted(self.captures.items()):
            start = Capture.from_msg(c).start
            with self.lock:
                beats = [(t, b) for t, b in self.beats if b.round == n]
            self.assertEqual([b.index for _, b in beats],
                             list(range(int(round(c.dur / 0.5)))),
                             'round %d: one beat each 0.5 s of the window' % n)
            for t, b in beats:
                self.assertAlmostEqual(b.header.stamp.to_sec(),
                                       start + 0.5 * b.index, places=6)
                self.assertEqual(b.bar_beat, b.index % 4)
                self.assertEqual(b.bpm, 120.0)
                self.assertLess(abs(t - b.header.stamp.to_sec()),
                                START_SANITY,
                                'beat %d published late' % b.index)

    def test_2c_header_tools(self):
        """rostopic delay and message_filters work on the beats: they
        read header.stamp (global; global = this host's clock here)."""
        beats = sum(int(round(c.dur / 0.5)) for c in self.captures.values())
        delay = self.beat_delay.get_delay()
        self.assertIsNotNone(delay, 'rostopic delay measured nothing')
        mean, lo, hi, _, n = delay
        # Its window counts the first message, which only starts it.
        self.assertEqual(n, beats)
        self.assertTrue(all(map(math.isfinite, (mean, lo, hi))), delay)
        rospy.loginfo('rostopic delay of /music/beat: mean %.2f ms, '
                      'min %.2f, max %.2f over %d beats', mean * 1e3,
                      lo * 1e3, hi * 1e3, n)
        for r, c in sorted(self.captures.items()):
            start = Capture.from_msg(c).start
            window = self.beat_cache.getInterval(
                rospy.Time.from_sec(start - 0.25),
                rospy.Time.from_sec(start + c.dur))
            self.assertEqual([(b.round, b.index) for b in window],
                             [(r, i) for i in range(int(round(c.dur / 0.5)))],
                             'message_filters.Cache by header.stamp')

    def test_3_outcome_motion(self):
        _, end = self.window()
        with self.lock:
            odom = [o for _, o in self.odom]
            after = [o for t, o in self.odom if t > end + 0.1]
            cmds_after = [c for t, c in self.cmds if t > end + 0.1]
            leds = [v for t, v in self.leds if t > end]
            sounds = [v for t, v in self.sounds if t > end]
        self.assertTrue(odom and after, 'no odometry after the window')
        final = odom[-1]
        if self.expect == 'no_winner':
            self.assertTrue(all(c == (0.0, 0.0) for c in cmds_after),
                            'moved after a no_winner round')
            ref = after[0]
            for o in after:
                self.assertLess(math.hypot(o[1] - ref[1], o[2] - ref[2]),
                                1e-4)
                self.assertLess(
                    abs(wrap_degrees(math.degrees(o[3] - ref[3]))), 0.05)
            self.assertEqual(leds, [])
            self.assertEqual(sounds, [])
            return
        bearing = self.bearings[int(self.expect[-1]) - 1]
        heading = math.degrees(final[3])
        rospy.loginfo('final heading %.2f deg, winner at %.1f deg; '
                      'position (%.3f, %.3f) m', heading, bearing, final[1],
                      final[2])
        self.assertLess(abs(wrap_degrees(heading - bearing)),
                        HEADING_TOLERANCE)
        self.assertLess(math.hypot(final[1], final[2]), 0.05)
        approach = max(math.hypot(o[1], o[2]) for o in after)
        self.assertGreater(approach, 0.2, 'no approach toward the winner')
        self.assertIn(Led.GREEN, leds)
        self.assertEqual(leds[-1], Led.BLACK)
        self.assertIn(Sound.CLEANINGEND, sounds)
        with self.lock:                   # the base's republished state
            sim_leds = [v for _, v in self.sim_leds]
        self.assertIn(Led.GREEN, sim_leds)
        self.assertEqual(sim_leds[-1], Led.BLACK)

    def test_5_bad_decisions_ignored(self):
        if self.expect != 'no_winner':
            self.skipTest('sent in the no_winner round only')
        text = '\n'.join(self.errors)
        self.assertIn('winner=7 is outside [0, 2]', text)
        self.assertTrue('round_future' in text or 'not a round this robot '
                        'was scheduled in' in text, text)
        self.assertIn("outcome='bogus' is not one of", text)
        with self.lock:
            moved = [c for t, c in self.cmds
                     if t > self.bad_sent and c != (0.0, 0.0)]
            leds = [v for t, v in self.leds if t > self.bad_sent]
        self.assertEqual(moved, [])
        self.assertEqual(leds, [])

    def test_4_limits(self):
        with self.lock:
            cmds = list(self.cmds)
            odom = [o for _, o in self.odom]
        self.assertGreater(len(cmds), 100)
        for _, c in cmds:
            self.assertLessEqual(abs(c[0]), LIMITS.linear)
            self.assertLessEqual(abs(c[1]), LIMITS.angular)
        # Accelerations from arrival times, which jitter by a few ms (a
        # late command arrives close to the next one): over 1 and 10
        # commands, with 30 ms of slack.
        for span in (1, 10):
            for (t0, a), (t1, b) in zip(cmds, cmds[span:]):
                dt = t1 - t0 + 0.030
                self.assertLessEqual(abs(b[0] - a[0]) / dt,
                                     LIMITS.linear_accel, (t1, a, b))
                self.assertLessEqual(abs(b[1] - a[1]) / dt,
                                     LIMITS.angular_accel, (t1, a, b))
        self.assertEqual(cmds[-1][1], (0.0, 0.0), 'no explicit zero at the '
                         'end')
        peak_w = max(abs(o[5]) for o in odom)
        self.assertGreater(peak_w, 0.3, 'the robot never turned')
        for a, b in zip(odom, odom[1:]):
            dt = b[0] - a[0]
            self.assertLessEqual(abs(b[4]), LIMITS.linear + 1e-9)
            self.assertLessEqual(abs(b[5]), LIMITS.angular + 1e-9)
            if dt > 0:
                self.assertLessEqual(abs(b[4] - a[4]) / dt,
                                     LIMITS.linear_accel * 1.001)
                self.assertLessEqual(abs(b[5] - a[5]) / dt,
                                     LIMITS.angular_accel * 1.001)
        # A moving command always has a successor within the timeout (by
        # this node's arrivals, when real-time: else load delays them):
        # the base never had to stop the robot itself.
        for (t0, a), (t1, _) in zip(cmds, cmds[1:]):
            if a != (0.0, 0.0) and self.realtime:
                self.assertLess(t1 - t0, CMD_TIMEOUT, 'no command for '
                                '%.2f s after %s' % (t1 - t0, a))
        self.assertTrue(self.diag, 'no diagnostics from kobuki_sim')
        rospy.loginfo('kobuki_sim counters: %s', self.diag)
        for key in ('velocity_clamped', 'refused'):
            self.assertEqual(self.diag[key], '0', '%s: %s' % (key, self.diag))
        commands = int(self.diag['commands'])
        self.assertLessEqual(int(self.diag['accel_limited']),
                             ACCEL_LIMITED_SHARE * commands,
                             'the base slewed often: %s' % self.diag)


if __name__ == '__main__':
    rostest.rosrun('hri_sync', 'dj_rob_round', DjRobRound)
