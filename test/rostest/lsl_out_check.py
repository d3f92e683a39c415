#!/usr/bin/python3
"""Checks LSL out (issue 21 items 2 and 7): reads nodes/lsl_outlet's
marker stream back with pylsl, as LabRecorder would, on the true clock.

Each marker's LSL stamp, mapped to this process's clock by LSL's time
correction (fitted with drift, ``hri_sync.sensors.lsl.CorrectionFit``),
is this host's true time here; it must be within the marker's ``bound``
plus the correction's bound plus ``~margin`` of the event's global time
as the ROS topics give it (sync_time, the capture window from
capture_data, each client_result, the decision), global being the time
server's, the true clock.  Every event of each round read must be there.
With ``~connect_after_round`` k, the reader connects only after round
k's decision: the markers of rounds 1..k had no reader, and the outlet
must say so on /diagnostics (markers_unread, unread_by_round) and go on.
"""
import threading
import time
import unittest

from hri_sync.ros.node import init_checker  # noqa: E402
from hri_sync.ros.timers import wait_for  # noqa: E402
from hri_sync.tools import venv

venv.ensure(['pylsl'], 'lsl_out_check', __file__)

import pylsl  # noqa: E402
import rospy  # noqa: E402
import rostest  # noqa: E402
from diagnostic_msgs.msg import DiagnosticArray  # noqa: E402
from std_msgs.msg import Header  # noqa: E402
from std_srvs.srv import Trigger  # noqa: E402

from hri_sync.msg import (ActionEnd, ActionStart, CaptureData,  # noqa: E402
                          ClientResult, Decision, DpmState, SyncTime)
from hri_sync.sensors.lsl import CorrectionFit  # noqa: E402
from hri_sync.tools import lsl_io  # noqa: E402
from hri_sync.tools.lsl_markers import parse_marker  # noqa: E402


class LslOutCheck(unittest.TestCase):

    def setUp(self):
        self.rounds = int(rospy.get_param('~rounds', 2))
        self.clients = rospy.get_param('~clients', 'a').split(',')
        self.after = int(rospy.get_param('~connect_after_round', 0))
        self.margin = float(rospy.get_param('~margin', 0.002))
        self.lock = threading.Lock()
        self.truth = {}     # (round, event, client) -> global time
        self.markers = []   # (LSL stamp, text)
        self.unread = {}
        self.fit = CorrectionFit()
        # DJ Rob's action start: this checker stands in for turtlebot_gesture.
        self.action_pub = rospy.Publisher('/dj_rob/action_start',
                                          ActionStart, queue_size=10)
        # And for action_client (client 'actions'): an action's end.
        self.end_pub = rospy.Publisher('/actions/action_end', ActionEnd,
                                       queue_size=10)
        # A forged decision (not the DM's): the outlet must not push it.
        self.forged_pub = rospy.Publisher('/decision', Decision,
                                          queue_size=10)
        for topic, kind, cb in (('/sync_time', SyncTime, self.on_sync),
                                ('/capture_data', CaptureData, self.on_cap),
                                ('/client_result', ClientResult,
                                 self.on_result),
                                ('/decision', Decision, self.on_decision),
                                ('/diagnostics', DiagnosticArray,
                                 self.on_diagnostics)):
            rospy.Subscriber(topic, kind, cb, queue_size=100)
        self.fed = set()
        self.connected = False
        self.acted = False
        for c in self.clients:
            rospy.Subscriber('/%s/dpm_state' % c, DpmState,
                             lambda m, c=c: m.samples and self.fed.add(c))

    def put(self, key, t):
        with self.lock:
            self.truth.setdefault(key, t)

    def on_sync(self, m):
        self.put((m.round, 'sync', ''), m.header.stamp.to_sec())

    def on_cap(self, m):
        start = m.header.stamp.to_sec() + m.str_aft
        self.put((m.round, 'window_start', ''), start)
        self.put((m.round, 'window_end', ''), start + m.dur)

    def on_result(self, m):
        self.put((m.round, 'result', m.client_id), m.header.stamp.to_sec())

    def on_decision(self, m):
        if m.reason == 'forged':    # our own, below
            return
        self.put((m.round, 'decision', ''), m.header.stamp.to_sec())
        if m.round == self.rounds and not self.acted:
            self.acted = True
            t = time.time()     # global = the true clock here
            self.action_pub.publish(ActionStart(
                header=Header(stamp=rospy.Time.from_sec(t)), round=m.round,
                client_id='dj_rob', action=ActionStart.DANCE,
                scheduled=rospy.Time.from_sec(t), offset=0.0,
                true_time=rospy.Time.from_sec(t)))
            self.put((m.round, 'action_start', 'dj_rob'), t)
            self.end_pub.publish(ActionEnd(
                header=Header(stamp=rospy.Time.from_sec(t)), round=m.round,
                client_id='actions', action='cheer',
                kind=ActionStart.SERVICE, event=ActionStart.DECISION,
                status=ActionEnd.TIMEOUT, reason='no answer in 5 s',
                started=rospy.Time.from_sec(t - 5.0), duration=5.0,
                timeout=5.0))
            self.put((m.round, 'action_end', 'actions'), t)
            self.forged_pub.publish(Decision(
                header=Header(stamp=rospy.Time.from_sec(t)), round=m.round,
                outcome=Decision.NO_WINNER, reason='forged'))

    def on_diagnostics(self, m):
        for s in m.status:
            if 'lsl_outlet' in s.name and s.name.endswith('lsl'):
                with self.lock:
                    self.unread = {kv.key: kv.value for kv in s.values}

    def run_rounds(self):
        """Start each round (the server has rounds:=0) once every DPM
        has had a sample (a loaded machine can start a sensor late), each
        after the last one's end."""
        self.assertTrue(wait_for(lambda: self.fed >= set(self.clients),
                                 120.0, 0.1), 'sensors never delivered')
        start = rospy.ServiceProxy('/control_module/start_round', Trigger)
        start.wait_for_service(60.0)
        for n in range(1, self.rounds + 1):
            if n > self.after:      # LSL gives a reader what comes after
                wait_for(lambda: self.connected, 60.0, 0.05)
            rospy.loginfo('lsl_out_check: round %d: %s', n,
                          start().message)     # returns at the round's end

    def read(self, deadline):
        """Connect (after round ``after``'s decision), then pull markers
        and time corrections until the last round's decision + 2 s."""
        threading.Thread(target=self.run_rounds, daemon=True).start()
        while (self.after, 'decision', '') not in self.truth and \
                self.after and time.time() < deadline:
            time.sleep(0.05)
        infos = lsl_io.resolve(name='hri_sync_events', timeout=30.0)
        self.assertTrue(infos, 'no LSL stream hri_sync_events found')
        inlet = pylsl.StreamInlet(infos[0], recover=False)
        inlet.open_stream(10.0)
        self.connected = True
        rospy.loginfo('lsl_out_check: reading %s', lsl_io.describe(infos[0]))
        done = None
        while time.time() < deadline and (done is None or
                                          time.time() < done):
            c, remote, rtt = lsl_io.time_correction_ex(inlet, 5.0)
            self.fit.add(remote + c, c, rtt)
            samples, stamps = inlet.pull_chunk(timeout=0.2)
            with self.lock:
                self.markers += [(t, s[0]) for s, t in zip(samples, stamps)]
                if done is None and (self.rounds, 'decision', '') in \
                        self.truth:
                    done = time.time() + 2.0
        return lsl_io.wall_minus_lsl()

    def expected(self, n):
        return [(n, e, '') for e in ('sync', 'window_start', 'window_end',
                                     'decision')] + \
            [(n, 'result', c) for c in self.clients] + \
            ([(n, 'action_start', 'dj_rob'), (n, 'action_end', 'actions')]
             if n == self.rounds else [])

    def test_markers(self):
        deadline = time.time() + float(rospy.get_param('~timeout', 240))
        offset = self.read(deadline)
        seen = {}
        for stamp, text in self.markers:
            d = parse_marker(text)
            key = (d['round'], d['event'], d.get('client', ''))
            # The fit's time axis is this host's LSL clock.
            local = stamp + self.fit.correction(self.fit.ref)
            true = stamp + self.fit.correction(local) + offset
            seen[key] = (true, d)
        worst = 0.0
        for n in range(self.after + 1, self.rounds + 1):
            for key in self.expected(n):
                self.assertIn(key, seen, 'no marker %s' % (key,))
                self.assertIn(key, self.truth, 'no ROS event %s' % (key,))
                true, d = seen[key]
                err = true - self.truth[key]
                bound = d['bound'] + self.fit.bound(true - offset)
                worst = max(worst, abs(err))
                rospy.loginfo('lsl_out_check: %s: marker %+.3f ms from the '
                              'event (bound %.3f ms)', key, err * 1e3,
                              bound * 1e3)
                self.assertLessEqual(abs(err), bound + self.margin, key)
                self.assertAlmostEqual(d['global_time'], self.truth[key],
                                       places=5)
        rospy.loginfo('lsl_out_check: worst marker error %.3f ms', worst * 1e3)
        self.assertFalse([d for _, d in seen.values()
                          if d.get('reason') == 'forged'],
                         'a forged decision became a marker')
        for n in range(1, self.after + 1):
            self.assertFalse([k for k in seen if k[0] == n],
                             'round %d markers read before connecting' % n)
        if self.after:
            with self.lock:
                unread = dict(self.unread)
            self.assertGreater(int(unread.get('markers_unread', 0)), 0,
                               unread)
            self.assertIn('1: ', unread.get('unread_by_round', ''))


if __name__ == '__main__':
    init_checker('lsl_out_check')
    rostest.rosrun('hri_sync', 'lsl_out_check', LslOutCheck)
