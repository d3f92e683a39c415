#!/usr/bin/python3
"""Checks action_client (issue 19) from outside, over one round.

Serves what the actions of test/rostest/action_client.yaml use (the
services /action_check/mark, /action_check/refuse (success=false) and
/action_check/stuck (never answers), the actionlib server
/action_check/count), publishes the participants' constant samples so
participant 1 wins, and records every ActionStart and ActionEnd and what
reached each receiver, with this process's (unfaked) clock.  Then
checks, per action:
- it is reported exactly once (and the actions whose decision filter
  does not match, cheer_right and on_tie, not at all);
- its scheduled time is its event's (CR_T + STR_AFT, the window end or
  the decision's stamp) plus its offset, to the microsecond;
- its report is consistent: offset = header.stamp - scheduled, LATE
  exactly when the offset passes the tolerance (with a reason), OK
  otherwise; the true start falls near the scheduled time (global =
  true here: the time server serves this host's clock).  The bound,
  START_SANITY, catches a wrong schedule or clock (seconds under the
  skewed test's fake clock), not load;
- the receiver got it: the message (stamped with the action's actual
  global start), the service request, the goal (a=2, b=3), the
  command's output (its own clock's time, after the node's local_time);
- the three that cannot begin are FAILED with their reason: a service
  nobody serves, a program that does not exist, no actionlib server;
- an action due 1 s before the decision's stamp begins at the decision,
  LATE with its lateness, and with a max_late of 0.5 s it does not begin
  (FAILED, 'not run');
- each action that began ends once (ActionEnd), after its start, with
  its status: OK (the messages, the answered service, the goal, the
  command exiting 0), FAILED (success=false, exit status 3) or TIMEOUT
  past its 1 s timeout (the service that never answers: its connection
  closed; the command that never exits and ignores SIGTERM: its process
  group killed 2 s after the SIGTERM, its background child too); one
  that did not begin has no end.  Order and statuses only: no bound on
  how long an end takes.
"""
import math
import os
import re
import shutil
import threading
import time
import unittest
import xmlrpc.client

import actionlib
import rosgraph
import rospy
import rostest
from actionlib.msg import TwoIntsAction, TwoIntsResult
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from geometry_msgs.msg import PointStamped
from std_msgs.msg import String
from std_srvs.srv import (SetBool, SetBoolResponse, Trigger,
                          TriggerResponse)

from constant_samples import publish_constant_samples
from hri_sync.msg import ActionEnd, ActionStart, CaptureData, Decision
from hri_sync.ros.node import init_checker
from hri_sync.wire.protocol import Capture

START_SANITY = 0.25          # s, see the docstring
ARRIVAL_SANITY = 1.0         # s, from a start to its receiver (transport,
                             # this process's threads under load)
COMMAND_SANITY = 60.0        # s, from the command's start to its output
STARTED = {'light': ('publish', 'window_start', -0.2),
           'mark': ('service', 'window_start', 0.0),
           'stimulus': ('command', 'window_start', 0.5),
           'count': ('actionlib', 'window_end', 0.0),
           'cheer_left': ('publish', 'decision', 0.3),
           'late_cue': ('publish', 'decision', -1.0),
           'stuck': ('service', 'window_start', 0.3),
           'refused': ('service', 'window_start', 0.3),
           'exit3': ('command', 'window_start', 0.3),
           'sleeper': ('command', 'window_start', 0.3)}
FAILING = {'missing_service': ('service', 'window_end', 0.0,
                               'nobody_serves_this'),
           'bad_command': ('command', 'window_end', 0.0, 'No such file'),
           'absent_server': ('actionlib', 'window_end', 0.0,
                             'no actionlib server'),
           'stale_cue': ('publish', 'decision', -1.0, 'not run: ')}
# How each action that began ends: status, timeout (s), words of the reason.
ENDS = {'light': (ActionEnd.OK, 0.0, ''),
        'mark': (ActionEnd.OK, 5.0, ''),
        'stimulus': (ActionEnd.OK, 30.0, ''),
        'count': (ActionEnd.OK, 30.0, ''),
        'cheer_left': (ActionEnd.OK, 0.0, ''),
        'late_cue': (ActionEnd.OK, 0.0, ''),
        'stuck': (ActionEnd.TIMEOUT, 1.0, 'its connection closed'),
        'refused': (ActionEnd.FAILED, 5.0, 'success=false: busy'),
        'exit3': (ActionEnd.FAILED, 30.0, 'exited with status 3'),
        'sleeper': (ActionEnd.TIMEOUT, 1.0,
                    'its process group killed (SIGKILL 2 s after SIGTERM)')}


class ActionClientRound(unittest.TestCase):
    """One round, observed end to end."""

    @classmethod
    def setUpClass(cls):
        init_checker('action_check')
        # The commands' output folder, this launch's own (~out).
        cls.out = rospy.get_param('~out')
        shutil.rmtree(cls.out, ignore_errors=True)
        os.makedirs(cls.out)
        cls.lock = threading.Lock()
        cls.starts, cls.lights, cls.cheers, cls.marks, cls.goals, \
            cls.cues, cls.ends, cls.stucks = [], [], [], [], [], [], [], []
        cls.capture = cls.decision = None
        cls.over = threading.Event()
        sub = rospy.Subscriber
        observers = [
            sub('/actions/action_start', ActionStart, cls.rec, 'starts',
                queue_size=100),
            sub('/actions/action_end', ActionEnd, cls.rec, 'ends',
                queue_size=100)]
        sub('/action_check/light', PointStamped, cls.rec, 'lights')
        sub('/action_check/cheer', String, cls.rec, 'cheers')
        sub('/action_check/cue', String, cls.rec, 'cues')
        observers += [
            sub('/capture_data', CaptureData,
                lambda m: setattr(cls, 'capture', m)),
            sub('/decision', Decision, lambda m: setattr(cls, 'decision', m))]
        cls.diag = None
        sub('/diagnostics', DiagnosticArray, cls.on_diag)
        rospy.Service('~mark', SetBool, cls.on_mark)
        rospy.Service('~refuse', Trigger,
                      lambda req: TriggerResponse(success=False,
                                                  message='busy'))
        rospy.Service('~stuck', Trigger, cls.on_stuck)
        cls.server = actionlib.SimpleActionServer(
            '~count', TwoIntsAction, cls.on_goal, auto_start=False)
        cls.server.start()
        publish_constant_samples({'a': 2.0, 'b': 1.0}, observers=observers)
        deadline = time.time() + 90.0
        while time.time() < deadline and not (
                cls.decision and len(cls.starts) >= len(STARTED) +
                len(FAILING) and len(cls.ends) >= len(ENDS)):
            time.sleep(0.1)
        time.sleep(3.0)              # any report that should not come

    @classmethod
    def tearDownClass(cls):
        cls.over.set()
        shutil.rmtree(cls.out, ignore_errors=True)

    @classmethod
    def rec(cls, msg, key):
        with cls.lock:
            getattr(cls, key).append((time.time(), msg))

    @classmethod
    def on_diag(cls, msg):
        for s in msg.status:
            if s.hardware_id == 'actions' and s.name.endswith(': actions'):
                cls.diag = s

    @classmethod
    def on_mark(cls, req):
        cls.rec(req, 'marks')
        return SetBoolResponse(success=True, message='marked')

    @classmethod
    def on_stuck(cls, req):
        """Answers only when the test is over (the client gave up)."""
        cls.rec(req, 'stucks')
        cls.over.wait(600.0)
        return TriggerResponse(success=True, message='too late')

    @classmethod
    def on_goal(cls, goal):
        cls.rec(goal, 'goals')
        cls.server.set_succeeded(TwoIntsResult(sum=goal.a + goal.b))

    def reports(self):
        self.assertIsNotNone(self.capture, 'no capture_data seen')
        self.assertIsNotNone(self.decision, 'no decision seen')
        with self.lock:
            out = {}
            for _, m in self.starts:
                self.assertNotIn(m.action, out, 'reported twice')
                out[m.action] = m
        return out

    def test_1_the_matching_actions_are_reported_once(self):
        self.assertEqual(self.decision.outcome, Decision.WINNER)
        self.assertEqual(self.decision.winner, 1)
        self.assertEqual(sorted(self.reports()),
                         sorted(list(STARTED) + list(FAILING)))

    def test_2_scheduled_on_the_events_and_consistent(self):
        c = Capture.from_msg(self.capture)
        base = {'window_start': c.start, 'window_end': c.end,
                'decision': self.decision.header.stamp.to_sec()}
        for name, m in self.reports().items():
            kind, event, offset = (STARTED.get(name) or FAILING[name])[:3]
            self.assertEqual((m.kind, m.event, m.round, m.client_id),
                             (kind, event, self.capture.round, 'actions'))
            self.assertAlmostEqual(m.scheduled.to_sec(),
                                   base[event] + offset, delta=1e-6,
                                   msg=name)
            actual = m.header.stamp.to_sec()
            self.assertAlmostEqual(m.offset, actual - m.scheduled.to_sec(),
                                   delta=1e-6, msg=name)
            due = m.scheduled.to_sec() + (1.0 if name.endswith('_cue')
                                          else 0.0)   # see test_5
            self.assertLess(abs(m.true_time.to_sec() - due), START_SANITY,
                            name)
            self.assertGreater(m.local_time.to_sec(), 0.0, name)
            if name in STARTED:
                late = m.offset > m.tolerance
                self.assertEqual(m.status, ActionStart.LATE if late
                                 else ActionStart.OK, (name, m.reason))
                if late:
                    self.assertIn('after its scheduled time', m.reason)

    def test_3_the_receivers_got_them(self):
        r = self.reports()
        with self.lock:
            lights, cheers = list(self.lights), list(self.cheers)
            marks, goals = list(self.marks), list(self.goals)
        self.assertEqual(len(lights), 1)
        light = lights[0][1]
        self.assertEqual((light.header.frame_id, light.point.x,
                          light.point.y), ('lamp', 1.0, 2.0))
        self.assertAlmostEqual(light.header.stamp.to_sec(),
                               r['light'].header.stamp.to_sec(),
                               delta=START_SANITY)   # both the client's
        self.assertEqual([m.data for _, m in cheers], ['left'])
        self.assertEqual([m.data for _, m in marks], [True])
        self.assertEqual([(g.a, g.b) for _, g in goals], [(2, 3)])
        for (t, _), name in ((lights[0], 'light'), (marks[0], 'mark'),
                             (goals[0], 'count'), (cheers[0], 'cheer_left')):
            self.assertGreaterEqual(t, r[name].true_time.to_sec() - 0.001,
                                    name)
            self.assertLess(t - r[name].true_time.to_sec(), ARRIVAL_SANITY,
                            name)
        # The command's own clock, once its interpreter is up (seconds on
        # a loaded machine: only the order and the round are checked).
        with open(os.path.join(self.out, 'stimulus')) as f:
            ran = float(f.read())
        self.assertGreaterEqual(ran, r['stimulus'].local_time.to_sec())
        self.assertLess(ran - r['stimulus'].local_time.to_sec(),
                        COMMAND_SANITY)

    def test_4_what_cannot_begin_fails_with_its_reason(self):
        r = self.reports()
        for name, (_, _, _, words) in FAILING.items():
            self.assertEqual(r[name].status, ActionStart.FAILED, name)
            self.assertIn(words, r[name].reason, name)
        self.assertFalse(math.isnan(r['bad_command'].offset))

    def test_5_late_says_why_and_max_late_skips(self):
        r = self.reports()
        late, stale = r['late_cue'], r['stale_cue']
        self.assertEqual(late.status, ActionStart.LATE)
        self.assertGreater(late.offset, 1.0 - START_SANITY)
        self.assertIn('after its scheduled time (tolerance 5.00 ms)',
                      late.reason)
        self.assertIn('max_late 500.0 ms', stale.reason)
        with self.lock:
            cues = [m.data for _, m in self.cues]
        self.assertEqual(cues, ['late'])

    def test_6_diagnostics_name_the_failed(self):
        d = self.diag
        self.assertIsNotNone(d, 'no actions status on /diagnostics')
        self.assertEqual(d.level, DiagnosticStatus.ERROR)
        self.assertEqual(d.message, 'last firing failed: absent_server, '
                         'bad_command, missing_service, stale_cue; last end '
                         'failed: exit3, refused; last end timeout: '
                         'sleeper, stuck')
        values = {kv.key: kv.value for kv in d.values}
        self.assertEqual(int(values['failed']), len(FAILING))
        self.assertTrue(values['late_cue'].startswith('late in round 1'))
        self.assertEqual(int(values['ended_timeout']), 2)
        self.assertTrue(values['stuck end'].startswith('timeout in round 1'))

    def test_7_each_action_that_began_ends_once_with_its_status(self):
        starts = self.reports()
        with self.lock:
            ends = [m for _, m in self.ends]
            stucks = list(self.stucks)
        self.assertEqual(sorted(m.action for m in ends), sorted(ENDS))
        self.assertEqual(len(stucks), 1, 'the stuck service was not called')
        for m in ends:
            status, timeout, words = ENDS[m.action]
            start = starts[m.action]
            self.assertIn(start.status, (ActionStart.OK, ActionStart.LATE))
            self.assertEqual((m.round, m.client_id, m.kind, m.event),
                             (start.round, 'actions', start.kind,
                              start.event), m.action)
            self.assertEqual((m.status, m.timeout), (status, timeout),
                             (m.action, m.reason))
            self.assertIn(words, m.reason, m.action)
            self.assertEqual(m.started, start.header.stamp, m.action)
            self.assertAlmostEqual(
                m.duration, (m.header.stamp - m.started).to_sec(),
                delta=1e-6, msg=m.action)
            self.assertGreaterEqual(m.duration, 0.0, m.action)
            if status == ActionEnd.TIMEOUT:
                self.assertIn('no end', m.reason)
                self.assertGreater(m.duration, timeout * 0.99, m.action)

    def test_8_a_timed_out_command_is_killed_with_its_group(self):
        node = rosgraph.Master('/action_check').lookupNode('/actions')
        code, _, pid = xmlrpc.client.ServerProxy(node).getPid(
            '/action_check')
        self.assertEqual(code, 1)
        with open(os.path.join(self.out, 'sleeper.%d' % pid)) as f:
            child = int(f.read())
        try:
            with open('/proc/%d/stat' % child) as f:
                state = re.sub(r'^.*\) ', '', f.read()).split()[0]
        except FileNotFoundError:
            state = 'gone'
        self.assertIn(state, ('gone', 'Z'), 'sleep 300 still runs')


if __name__ == '__main__':
    rostest.rosrun('hri_sync', 'action_client_check', ActionClientRound)
