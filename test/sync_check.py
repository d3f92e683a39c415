#!/usr/bin/python3
"""Checks clock sync and scheduled capture against true time (issue 2).

A reference sensor on the true clock writes each sample's true time into
the sample; clients (some under libfaketime) stamp samples in their global
time.  For every round this checks: every ACK ok, each ACK offset near the
client's fake offset (~expected_offsets), each client's clock error at the
window start and end within ~max_clock_error of zero, the clients' start
skew within ~max_skew, the same first sample everywhere, results and a
decision arrive.
"""
import math
import time
import unittest

import rospy
import rostest

from hri_sync.ros.params import csv_list
from hri_sync.ros.round_log import RoundLog
from hri_sync.timing.skew import client_timing, start_skew


class SyncCheck(unittest.TestCase):
    """Ground-truth checks of the timing model's rounds."""

    def test_rounds(self):
        clients = csv_list(rospy.get_param('~clients'))
        rounds = rospy.get_param('~rounds')
        expected = rospy.get_param('~expected_offsets', {})
        max_error = rospy.get_param('~max_clock_error', 0.002)
        max_skew = rospy.get_param('~max_skew', 0.001)
        log = RoundLog(clients, 'hri_sync/Sample')
        deadline = time.monotonic() + rospy.get_param('~timeout', 150.0)
        t0 = time.monotonic()
        while time.monotonic() < deadline and not all(
                log.rounds.get(n, {}).get('decision') for n in
                range(1, rounds + 1)):
            time.sleep(0.1)
        time.sleep(1.0)
        log.assign_captured()
        elapsed = time.monotonic() - t0 + 10.0  # the clients ran before us
        for n in range(1, rounds + 1):
            r = log.rounds.get(n)
            self.assertIsNotNone(r, 'round %d never happened' % n)
            self.assertIsNotNone(r['decision'], 'round %d: no decision' % n)
            self.assertIsNotNone(r['capture'], 'round %d: no capture' % n)
            self.assertEqual(sorted(r['capture'].clients), sorted(clients))
            starts, ends = [], []
            for c in clients:
                ack = r['acks'].get(c)
                self.assertTrue(ack and ack.ok, 'round %d: %s ACK %r'
                                % (n, c, ack))
                want = -float(expected.get(c, 0.0))
                # The fake clock drifts by up to 200 ppm since it started.
                slack = 0.002 + 200e-6 * elapsed
                self.assertLess(abs(ack.offset - want), slack,
                                'round %d: %s ACK offset %.6f s, fake offset '
                                '%.6f s' % (n, c, ack.offset, want))
                res = r['results'].get(c)
                self.assertTrue(res, 'round %d: no result from %s' % (n, c))
                self.assertEqual(res.status, 'ok', 'round %d %s: %s'
                                 % (n, c, res.status))
                kept = r['captured'].get(c, [])
                self.assertEqual(len(kept), res.frames)
                start = client_timing(c, kept)
                end = client_timing(c, kept, at_end=True)
                rospy.loginfo('round %d %s: ACK offset %+.6f s; clock error '
                              'at start %+.3f ms, at end %+.3f ms; first '
                              'sample %d; wake-up %.2f ms late', n, c,
                              ack.offset, start.clock_error * 1e3,
                              end.clock_error * 1e3, start.first_index,
                              res.wake_lateness * 1e3)
                for t in (start, end):
                    self.assertLess(abs(t.clock_error), max_error,
                                    'round %d: %s clock error %.3f ms'
                                    % (n, c, t.clock_error * 1e3))
                starts.append(start)
                ends.append(end)
            skew = start_skew(starts)
            rospy.loginfo('round %d: start skew %.3f ms, end skew %.3f ms',
                          n, skew * 1e3, start_skew(ends) * 1e3)
            self.assertLess(skew, max_skew, 'round %d: start skew %.3f ms'
                            % (n, skew * 1e3))
            self.assertEqual(len({t.first_index for t in starts}), 1,
                             'round %d: first samples differ: %s' % (
                                 n, {t.client_id: t.first_index
                                     for t in starts}))
            self.assertTrue(math.isfinite(r['capture'].str_aft))


if __name__ == '__main__':
    rospy.init_node('sync_check')
    rostest.rosrun('hri_sync', 'sync_check', SyncCheck)
