#!/usr/bin/python3
"""Checks several robots dancing in unison (issue 19 item 2) from outside.

Each robot (~robots: client ids, each a namespace) runs under its own
libfaketime clock (~clocks, the faketime specs in turn).  After ~rounds
rounds (hri_sync.ros.unison_watch records them) it checks:
- every robot's clock really is skewed (its clock_state's offset is its
  faketime offset, seconds) and synced (ok);
- in every round every robot dances, scheduled exactly at CR_T+STR_AFT,
  and the robots' starts (their raw true-clock readings at the first
  dance command) lie within START_SANITY of each other and of the
  schedule in true time (the time server serves this host's clock, so
  global = true).  The bound catches a robot on its own clock (seconds
  off), not load: how close the starts come (the issue's 1 ms) is
  measured by bench/robots_unison.py and logged here;
- heading agreement: every robot turns in every dance, and the robots'
  odometry headings, each put on the global clock by the robot's own
  clock model, agree within DANCE_SPREAD_P50 degrees over half of each
  dance (a robot a beat off would differ by tens of degrees), and within
  REST_SPREAD as each dance comes to rest and after the winner gesture.
"""
import math
import re
import time
import unittest

import rospy
import rostest

from hri_sync.ros.node import init_checker
from hri_sync.ros.unison_watch import RobotsWatch
from hri_sync.tools.unison import heading_spreads

START_SANITY = 0.25          # s, see the docstring
DANCE_SPREAD_P50 = 5.0       # deg
REST_SPREAD = 2.0            # deg
OFFSET_TOLERANCE = 0.1       # s: clock_state offset vs the faketime spec


class RobotsUnison(unittest.TestCase):
    """Rounds of several robots, observed end to end."""

    @classmethod
    def setUpClass(cls):
        init_checker('robots_unison_check')
        robots = rospy.get_param('~robots').split(',')
        cls.rounds = int(rospy.get_param('~rounds'))
        specs = [c.strip() for c in rospy.get_param('~clocks').split(';')
                 if c.strip() not in ('', 'none')]
        cls.specs = {r: specs[i % len(specs)] if specs else ''
                     for i, r in enumerate(robots)}
        cls.watch = w = RobotsWatch(robots)
        deadline = time.time() + 90.0 + 30.0 * cls.rounds
        while len(w.decisions) < cls.rounds and time.time() < deadline:
            time.sleep(0.2)
        time.sleep(9.0)             # the last winner gesture (about 6 s)

    def test_1_skewed_clocks(self):
        for r in self.watch.robots:
            with self.watch.lock:
                state = self.watch.clock.get(r)
            self.assertIsNotNone(state, '%s: no clock_state' % r)
            self.assertTrue(state.ok, '%s: %s' % (r, state.reason))
            m = re.match(r'([+-][0-9.]+)s', self.specs[r])
            fake = float(m.group(1)) if m else 0.0
            rospy.loginfo('%s: clock %r, offset to global %+.4f s', r,
                          self.specs[r], state.offset)
            self.assertLess(abs(state.offset + fake), OFFSET_TOLERANCE,
                            '%s runs on its own clock' % r)

    def test_2_starts_together(self):
        w = self.watch
        self.assertEqual(sorted(w.decisions), list(range(1, self.rounds + 1)))
        skews, missing = w.skews()
        self.assertEqual(missing, {}, 'robots that did not dance')
        starts = w.start_times()
        for n, capture in sorted(w.captures.items()):
            rospy.loginfo('round %d: start skew across %d robots %.3f ms '
                          '(true time); starts %s ms from the schedule', n,
                          len(w.robots), skews[n] * 1e3, ', '.join(
                              '%s %+.3f' % (r, (t - capture.start) * 1e3)
                              for r, t in sorted(starts[n].items())))
            self.assertLess(skews[n], START_SANITY, 'round %d' % n)
            for r, m in w.starts[n].items():
                self.assertAlmostEqual(m.scheduled.to_sec(), capture.start,
                                       places=6)
                self.assertLess(abs(starts[n][r] - capture.start),
                                START_SANITY, 'round %d %s' % (n, r))

    def test_3_headings_agree(self):
        w = self.watch
        tracks = w.sorted_tracks()
        for n, c in sorted(w.captures.items()):
            for r, track in tracks.items():
                turned = max((abs(h) for t, h in track
                              if c.start <= t <= c.end), default=0.0)
                self.assertGreater(turned, math.radians(20),
                                   'round %d: %s never turned' % (n, r))
            dance = sorted(math.degrees(s)
                           for s in w.dance_spreads(n, tracks))
            self.assertGreater(len(dance), 0.9 * c.dur / 0.02,
                               'round %d: poses over the dance' % n)
            p50 = dance[len(dance) // 2]
            rospy.loginfo('round %d: heading spread over the dance: p50 '
                          '%.3f deg, max %.3f deg', n, p50, dance[-1])
            self.assertLess(p50, DANCE_SPREAD_P50, 'round %d' % n)
            rest = heading_spreads(tracks, c.end - 0.1, c.end)
            self.assertTrue(rest)
            self.assertLess(math.degrees(max(rest)), REST_SPREAD,
                            'round %d: as the dance ends' % n)
        end = min(track[-1][0] for track in tracks.values())
        final = heading_spreads(tracks, end - 0.5, end)
        self.assertTrue(final)
        rospy.loginfo('heading spread after the last gesture: %.3f deg',
                      math.degrees(max(final)))
        self.assertLess(math.degrees(max(final)), REST_SPREAD)


if __name__ == '__main__':
    rostest.rosrun('hri_sync', 'robots_unison', RobotsUnison)
