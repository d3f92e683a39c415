#!/usr/bin/python3
"""Checks a round with a client whose time server is unreachable (issue 2).

The client must NACK with a reason naming the time server; then, with
~expect 'aborted', the round aborts with a reason naming the client and the
DM publishes an 'aborted' decision; with ~expect 'quorum', the round goes
on without it and the others' results and a decision arrive.  The round
is awaited for ~timeout s (a bound for a hang, not a figure), so a loaded
machine only makes it slower.
"""
import time
import unittest

import rospy
import rostest

from hri_sync.msg import RoundStatus
from hri_sync.ros.node import init_checker
from hri_sync.ros.params import csv_list
from hri_sync.ros.round_log import RoundLog


class UnreachableCheck(unittest.TestCase):
    """NACK, then abort or quorum, never a hang."""

    def test_round(self):
        clients = csv_list(rospy.get_param('~clients'))
        bad = rospy.get_param('~unreachable')
        expect = rospy.get_param('~expect')
        statuses = []
        rospy.Subscriber('/round_status', RoundStatus, statuses.append)
        log = RoundLog(clients)
        timeout = rospy.get_param('~timeout', 200.0)
        deadline = time.monotonic() + timeout
        # The ACKs, results and status come before the decision, each on
        # a connection of its own: a loaded checker may read them after.
        others = [c for c in clients if c != bad]

        def complete():
            r = log.rounds.get(1, {})
            if not r.get('decision') or not set(clients) <= set(r['acks']):
                return False
            if expect == 'aborted':
                return any(s.state == RoundStatus.ABORTED for s in statuses)
            return set(r['results']) >= set(others)
        while time.monotonic() < deadline and not complete():
            time.sleep(0.1)
        r = log.rounds.get(1)
        self.assertIsNotNone(r, 'no round happened')
        self.assertIsNotNone(r['decision'], 'no decision within %.0f s: hang'
                             % timeout)
        nack = r['acks'].get(bad)
        self.assertIsNotNone(nack, '%s sent no NACK' % bad)
        self.assertFalse(nack.ok)
        self.assertIn('did not answer', nack.reason)
        self.assertIn('127.0.0.1', nack.reason)
        for c in others:
            self.assertTrue(r['acks'][c].ok, '%s did not ACK' % c)
        if expect == 'aborted':
            aborted = [s for s in statuses if s.state == RoundStatus.ABORTED]
            self.assertTrue(aborted, 'round was not aborted: %s' % statuses)
            self.assertIn(bad, aborted[0].reason)
            self.assertIn(bad, aborted[0].refused)
            self.assertIsNone(r['capture'])
            self.assertEqual(r['decision'].outcome, 'aborted')
            self.assertIn(bad, r['decision'].reason)
        else:
            self.assertIsNotNone(r['capture'], 'no capture_data')
            self.assertEqual(sorted(r['capture'].clients),
                             sorted(c for c in clients if c != bad))
            for c in others:
                self.assertEqual(r['results'][c].status, 'ok')
            self.assertNotEqual(r['decision'].outcome, 'aborted')
            self.assertIn('%s has no usable result' % bad,
                          r['decision'].reason)


if __name__ == '__main__':
    init_checker('unreachable_check')
    rostest.rosrun('hri_sync', 'unreachable_check', UnreachableCheck)
