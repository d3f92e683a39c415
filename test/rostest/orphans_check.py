#!/usr/bin/python3
"""Checks that a dance-off killed with SIGKILL leaves no orphans (issue 11).

Starts ``dance_off.launch`` (both clients under skewed_client, a bag
being recorded) on this test's master and waits for its nodes.  Then,
one launch serving both checks: it kills the right client's
skewed_client with SIGKILL and checks that within ~deadline s none of
its descendant processes is alive any more (the lifelines of
hri_sync.ros.lifeline); then it kills the roslaunch, the left client's
skewed_client still running, and checks the same of every descendant of
the roslaunch, and that the bag was closed: no ``.bag.active`` left, a
``.bag`` there.  The deadline is a liveness bound far above what the
shutdown takes (a few seconds), not a performance figure.
"""
import os
import signal
import subprocess
import tempfile
import time
import unittest

import rosnode
import rospy
import rostest

from hri_sync.ros.node import init_checker
from hri_sync.tools import procs

NODES = ('/control_module', '/decision_module', '/time_server',
         '/left/cpm', '/left/dpm', '/right/cpm',
         '/right/dpm', '/left/sensor', '/right/sensor', '/recorder',
         '/dance_off_config', '/dj_rob', '/music', '/kobuki_sim')


def cmdline(pid):
    return procs.cmdline(pid, None)


class Orphans(unittest.TestCase):
    """kill -9 roslaunch: every node it started ends."""

    launch = None

    def tearDown(self):
        # A failure before the kill: stop the launch as Ctrl-C would.
        if self.launch is not None and self.launch.poll() is None:
            procs.stop_group(self.launch, timeout=30)

    def start(self):
        """Start the dance-off; returns its bag's path once it records."""
        folder = tempfile.mkdtemp(prefix='orphans_')
        bag = os.path.join(folder, 'round.bag')
        self.launch = subprocess.Popen(
            ['roslaunch', 'hri_sync', 'dance_off.launch', 'rounds:=0',
             'ntp_port:=%d' % rospy.get_param('~ntp_port'),
             'left_clock:=+1.5s x1.0001', 'right_clock:=+0.7s x0.9999',
             'bag:=' + bag,
             'left_seed:=4', 'right_seed:=21',
             'monitor_required:=false'],
            stdout=open(os.path.join(folder, 'launch.log'), 'w'),
            stderr=subprocess.STDOUT, start_new_session=True)
        deadline = time.monotonic() + 90.0
        while time.monotonic() < deadline and not (
                set(NODES) <= set(rosnode.get_node_names())
                and os.path.exists(bag + '.active')):
            time.sleep(0.5)
        missing = set(NODES) - set(rosnode.get_node_names())
        self.assertFalse(missing, 'nodes never came up: %s' % missing)
        self.assertTrue(os.path.exists(bag + '.active'), 'no bag recorded')
        time.sleep(2.0)
        return bag

    def kill(self, pid):
        """SIGKILL ``pid``; fail if a descendant of it outlives it by
        ~deadline s."""
        under = procs.descendants(pid)
        rospy.loginfo('%d processes under %d (%s); SIGKILL to it',
                      len(under), pid, cmdline(pid)[:60])
        os.kill(pid, signal.SIGKILL)

        def alive():
            table = procs.proc_table()
            return {p: cmdline(p) for p, info in under.items()
                    if p in table and table[p].live
                    and table[p].start == info.start}
        limit = rospy.get_param('~deadline', 60.0)
        t0 = time.monotonic()
        while alive() and time.monotonic() - t0 < limit:
            time.sleep(0.2)
        survivors = alive()
        rospy.loginfo('all gone after %.1f s' % (time.monotonic() - t0)
                      if not survivors else 'survivors: %s' % survivors)
        for p in survivors:
            os.kill(p, signal.SIGKILL)
        self.assertFalse(survivors, 'orphans %.0f s after the SIGKILL: %s'
                         % (limit, '; '.join(c[:100] for c in
                                             survivors.values())))

    def test_killed_skewed_client_then_roslaunch(self):
        bag = self.start()
        launched = {p: cmdline(p) for p in procs.descendants(self.launch.pid)}
        clients = {c: [p for p, line in launched.items()
                       if 'skewed_client' in line
                       and 'client_id:=%s' % c in line]
                   for c in ('left', 'right')}
        for c, pids in clients.items():
            self.assertEqual(len(pids), 1, 'no skewed_client for %s' % c)
        self.kill(clients['right'][0])
        self.assertIn(clients['left'][0], procs.descendants(self.launch.pid),
                      "the left client's skewed_client ended with the right's")
        self.kill(self.launch.pid)
        self.launch.wait()
        self.assertFalse(os.path.exists(bag + '.active'),
                         'the bag was left active')
        self.assertTrue(os.path.exists(bag), 'no closed bag')


if __name__ == '__main__':
    init_checker('orphans_check')
    rostest.rosrun('hri_sync', 'orphans_check', Orphans)
