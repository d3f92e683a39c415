#!/usr/bin/python3
"""Checks that a session survives its time server dying (issue 11).

Kills chronyd (SIGKILL) when round 1's capture_data arrives, then checks,
each within a deadline: the time_server node exits and the launch goes on
(it is not required); round 1 ends in a decision from both clients'
results; in round 2, client a (drift bound 15 ppm) ACKs in holdover and
client b (2 ms/s) NACKs because its grown uncertainty exceeds
~max_uncertainty, so round 2 aborts naming b and that reason; /diagnostics
says so (a's clock WARN in holdover, b's ERROR past its limit, the CM's
rounds WARN on the abort); round 3 happens too; the CM, the DM and both
clients' nodes stay alive.
"""
import os
import signal
import unittest

import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus

from hri_sync.msg import CaptureData, RoundStatus
from hri_sync.ros.node import init_checker
from hri_sync.ros.timers import wait_for
from hri_sync.ros.round_log import RoundLog
from hri_sync.ros.unique import node_pid
from hri_sync.tools.procs import alive, descendants

SURVIVORS = ['/control_module', '/decision_module', '/a/cpm', '/a/dpm',
             '/b/cpm', '/b/dpm']


def children(pid):
    """[(pid, command name)] of the live children of ``pid``."""
    return [(p, info.name) for p, info in descendants(pid).items()
            if info.ppid == pid]


class TimeServerDies(unittest.TestCase):
    """The time server dies; the session goes on and says why."""

    def test_session_survives(self):
        port = rospy.get_param('~ntp_port')
        server = '127.0.0.1:%d' % port
        log = RoundLog(['a', 'b'])
        statuses = []
        rospy.Subscriber('/round_status', RoundStatus, statuses.append)
        captures = []
        rospy.Subscriber('/capture_data', CaptureData, captures.append)
        diagnostics = []
        rospy.Subscriber('/diagnostics', DiagnosticArray,
                         lambda m: diagnostics.extend(m.status),
                         queue_size=100)

        def diagnosed(name, level, *parts):
            return any(s.name == name and s.level == level
                       and all(p in s.message for p in parts)
                       for s in list(diagnostics))

        def decision(n):
            return log.rounds.get(n, {}).get('decision')

        self.assertTrue(wait_for(lambda: any(c.round == 1 for c in captures),
                             60.0), 'no capture_data for round 1 in 60 s')
        ts_pid = node_pid('/time_server')
        self.assertIsNotNone(ts_pid, 'no /time_server node')
        chronyd = [p for p, comm in children(ts_pid) if comm == 'chronyd']
        self.assertEqual(len(chronyd), 1, 'chronyd not found under the '
                         'time_server node: %s' % children(ts_pid))
        os.kill(chronyd[0], signal.SIGKILL)
        rospy.loginfo('killed chronyd (pid %d) serving %s', chronyd[0],
                      server)
        self.assertTrue(wait_for(lambda: not alive(ts_pid), 10.0),
                        'the time_server node did not notice its chronyd '
                        'died')

        # The round in progress still ends in a decision.
        self.assertTrue(wait_for(lambda: decision(1), 30.0),
                        'round 1: no decision within 30 s of the kill')
        r1 = log.rounds[1]
        wait_for(lambda: len(r1['results']) == 2, 5.0)    # other publishers
        self.assertNotEqual(r1['decision'].outcome, 'aborted',
                            r1['decision'].reason)
        for c in ('a', 'b'):         # captured on the models in holdover
            self.assertIn(c, r1['results'], 'round 1: no result of %s' % c)
            self.assertIn(r1['results'][c].status, ('ok', 'partial'),
                          'round 1 result of %s' % c)

        # Round 2: a in holdover, b past its ~max_uncertainty.
        self.assertTrue(wait_for(lambda: decision(2), 40.0),
                        'round 2: no decision or abort within 40 s')
        for name in SURVIVORS:
            self.assertIsNotNone(node_pid(name), '%s died' % name)
        r2 = log.rounds[2]
        wait_for(lambda: len(r2['acks']) == 2 and any(
            s.round == 2 and s.state == RoundStatus.ABORTED
            for s in statuses), 5.0)
        a, b = r2['acks'].get('a'), r2['acks'].get('b')
        self.assertIsNotNone(a, 'no ACK from a in round 2')
        self.assertIsNotNone(b, 'no ACK from b in round 2')
        self.assertTrue(a.ok, a.reason)
        self.assertTrue(a.reason.startswith('holdover: no good sync for'),
                        a.reason)
        self.assertIn(server, a.reason)
        self.assertFalse(b.ok)
        self.assertIn('exceeds ~max_uncertainty 5.00 ms', b.reason)
        self.assertIn('no good sync for', b.reason)
        self.assertIn(server, b.reason)
        self.assertGreater(b.uncertainty, 0.005)
        aborted = [s for s in statuses if s.round == 2
                   and s.state == RoundStatus.ABORTED]
        self.assertTrue(aborted, 'round 2 was not aborted')
        self.assertIn('b refused (offset uncertainty', aborted[0].reason)
        self.assertEqual(list(aborted[0].refused), ['b'])
        self.assertEqual(r2['decision'].outcome, 'aborted')
        self.assertIn('~max_uncertainty', r2['decision'].reason)
        for name, level, parts in (
                ('a/cpm: clock', DiagnosticStatus.WARN,
                 ('holdover: no good sync for', server)),
                ('b/cpm: clock', DiagnosticStatus.ERROR,
                 ('exceeds its limit 5.000 ms', server)),
                ('b/cpm: rounds', DiagnosticStatus.WARN,
                 ('round 2: nacked',)),
                ('control_module: rounds', DiagnosticStatus.WARN,
                 ('round 2: aborted', 'b refused'))):
            self.assertTrue(wait_for(lambda: diagnosed(name, level, *parts),
                                 10.0),
                            '/diagnostics: no %s at level %d saying %s'
                            % (name, level, parts))

        # The session goes on: round 3 gets its outcome too.
        self.assertTrue(wait_for(lambda: decision(3), 40.0),
                        'round 3: no decision or abort within 40 s')
        self.assertIsNone(node_pid('/time_server'))


if __name__ == '__main__':
    init_checker('timeserver_dies_check')
    rostest.rosrun('hri_sync', 'timeserver_dies_check', TimeServerDies)
