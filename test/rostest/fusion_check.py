#!/usr/bin/python3
"""Checks the fusion node through a fault of one view (fusion_*.test).

Before the fault (~fault_after s) and after it: fused skeletons keep
coming (at least ~min_instants fused instants stamped in the SPAN s from
then, and 3 s of them or more, waited for up to 60 s: not a rate, which
load sets: a fusion starved on a machine running a dozen tests on two
cores skips instants to keep up, one CI run's 1 in a 3 s window), the
healthy views' bodies one person (or the fusion said, on its people
status, that it was behind: starved, it may lose a person), every joint
with a confidence unless only the faulty view gave the body (on a busy
machine the others may be left out of an instant) and the fault hides
that joint (``nan_joints``: the hands; ``wrong_pose``: any, a misplaced
view's joints being the fusion's guards' to leave out, its jump guard's
and its image test's: one CI run under load had a fused body of that
view alone without its right elbow), and the healthy views in at least
half the bodies; the diagnostics name the fault (~expect, a fault of
hri_sync.fusion.views) on view ~faulty's status, and every other view is
healthy (``none``) in most of its first 8 statuses or more after the
fault: under load a healthy view's skeletons may come 0.5 s apart and it
reads stalled for a status or two (one CI run had only two statuses of a
view by the time the instants were counted, one of them stalled), while
a fault put on the wrong view stays.
"""
import threading
import time
import unittest

import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray

from hri_sync.fusion.report import view_named
from hri_sync.msg import Skeleton
from hri_sync.ros.node import init_checker
from hri_sync.ros.timers import wait_for


class FusionFault(unittest.TestCase):

    STATUSES = 8    # each healthy view's statuses judged after the fault
    WINDOW = 3.0    # s of stamps at least that the fused instants span
    SPAN = 30.0     # s of stamps in which the fused instants are counted

    @classmethod
    def setUpClass(cls):
        init_checker('fusion_check')
        cls.lock = threading.Lock()
        cls.skeletons, cls.faults, cls.statuses = [], {}, []
        cls.people = []     # (time, message) of the fusion's people status
        rospy.Subscriber('/fused/skeleton', Skeleton, cls.on_skeleton)
        rospy.Subscriber('/diagnostics', DiagnosticArray, cls.on_diag)

    @classmethod
    def on_skeleton(cls, msg):
        with cls.lock:
            cls.skeletons.append((time.time(), msg))

    @classmethod
    def on_diag(cls, msg):
        with cls.lock:
            for s in msg.status:
                if s.name.endswith(': people'):
                    cls.people.append((time.time(), s.message))
                view = view_named(s.name)
                if view is not None:
                    faults = dict((v.key, v.value) for v in s.values)
                    cls.faults[view] = faults.get('faults', '')
                    cls.statuses.append((time.time(), view,
                                         cls.faults[view]))

    def newest(self):
        with self.lock:
            return max((m.header.stamp.to_sec() for _, m in self.skeletons),
                       default=0.0)

    def since(self, t0):
        """The fused skeletons stamped in the SPAN s from ``t0``."""
        with self.lock:
            return [m for _, m in self.skeletons
                    if t0 <= m.header.stamp.to_sec() <= t0 + self.SPAN]

    def instants_since(self, t0, least, what):
        """The fused skeletons stamped in the SPAN s from ``t0`` once one
        stamped WINDOW s after it has come and there are ``least`` or more
        (asserted; waited for up to 60 s)."""
        wait_for(lambda: len(self.since(t0)) >= least
                 and self.newest() > t0 + self.WINDOW
                 or self.newest() > t0 + self.SPAN, 60.0, 0.05)
        got = self.since(t0)
        self.assertGreaterEqual(len(got), least, '%s: fused instants in '
                                'the %.0f s from then' % (what, self.SPAN))
        return got

    def test_fault_named_and_fusion_goes_on(self):
        expect = rospy.get_param('~expect')
        least = rospy.get_param('~min_instants', 9)
        faulty = rospy.get_param('~faulty')
        self.assertTrue(wait_for(lambda: self.skeletons, 60.0, 0.1),
                        'no fused skeleton')
        self.instants_since(time.time() + 1.0, least, 'before the fault')
        self.assertTrue(wait_for(
            lambda: expect in self.faults.get(faulty, ''), 60.0, 0.1),
            'diagnostics never named %s on %s: %s'
            % (expect, faulty, self.faults))
        named = time.time()
        got = self.instants_since(named, least, 'after the fault')
        healthy = [m for m in got if set(m.sources) - {faulty}]
        ids = sorted({m.user_id for m in healthy})
        said, behind = self.people_since(named)
        self.assertTrue(len(ids) == 1 or behind,
                        "the healthy views' people %s, and the fusion never "
                        'said it was behind: %s' % (ids, said))
        hidden = {'nan_joints': {7, 8},
                  'wrong_pose': set(range(15))}.get(expect, set())
        for m in got:
            missing = {j for j, c in enumerate(m.confidence) if c <= 0}
            alone = set(m.sources) <= {faulty}
            self.assertTrue(missing <= (hidden if alone else set()),
                            'joints %s missing, views %s'
                            % (sorted(missing), m.sources))
        # A fusion starved of CPU (9 instants a second once, on CI beside
        # the other tests) fuses what came in time: as for its people
        # above, it must then have said it was behind.
        self.assertTrue(
            2 * len(healthy) >= len(got) or behind,
            'the healthy views gave %d of %d bodies, and the fusion never '
            'said it was behind: %s' % (len(healthy), len(got), said))
        wait_for(lambda: min(map(len, self.others(named, faulty).values()),
                             default=0) >= self.STATUSES, 60.0, 0.1)
        others = self.others(named, faulty)
        self.assertTrue(others, 'no status of the other views after the '
                        'fault')
        said, behind = self.people_since(named)
        for view, seen in others.items():
            # starved, the views' skeletons came late (stalled, bad
            # stamps): the fusion must have said it was behind
            self.assertTrue(2 * seen.count('none') > len(seen) or behind,
                            'view %s: %s; the fusion said %s'
                            % (view, seen, said))

    def people_since(self, t0):
        """The fusion's people statuses since ``t0``, and whether one
        said it was behind."""
        with self.lock:
            said = [m for t, m in self.people if t >= t0]
        return said, any('behind' in m for m in said)

    def others(self, t0, faulty):
        """Each view but ``faulty``: its faults in its statuses since
        ``t0``."""
        seen = {}
        with self.lock:
            for t, view, faults in self.statuses:
                if t >= t0 and view != faulty:
                    seen.setdefault(view, []).append(faults)
        return seen


if __name__ == '__main__':
    rostest.rosrun('hri_sync', 'fusion_check', FusionFault)
