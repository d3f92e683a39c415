#!/usr/bin/python3
"""Checks that a second system in a running system's namespace is refused
(test/rostest/duplicate_namespace.test).

Once the running system's CM is up, starts ``roslaunch hri_sync
dance_off.launch __ns:=~ns`` (its own time server port, ~ntp_port) and
checks:
- that launch ends by itself, and says "a system already runs in <ns>/"
  naming a node of the running system;
- the running system's CM, DM, CPMs and DPMs are the same processes
  (pids) before, after the second launch, and after ~rounds rounds
  started then (its CM serves ~start_round: rounds 0);
- each of those rounds is decided by the running system's DM, over its
  clients, and no round is decided twice.
"""
import os
import subprocess
import tempfile
import threading
import time
import unittest
import xmlrpc.client

import rosgraph
import rospy
import rostest
from std_srvs.srv import Trigger

from hri_sync.msg import Decision
from hri_sync.ros.node import init_checker
from hri_sync.tools.procs import stop_group

NODES = ('control_module', 'decision_module', 'left/cpm', 'left/dpm',
         'right/cpm', 'right/dpm')


def pids(master, ns):
    """{node: pid} of the running system's nodes that answer."""
    out = {}
    for n in NODES:
        name = '%s/%s' % (ns, n)
        try:
            code, _, pid = xmlrpc.client.ServerProxy(
                master.lookupNode(name)).getPid('/check')
        except (rosgraph.MasterException, OSError, xmlrpc.client.Error):
            continue
        if code == 1:
            out[name] = pid
    return out


class DuplicateNamespace(unittest.TestCase):
    """A second system in a taken namespace is refused."""

    @classmethod
    def setUpClass(cls):
        init_checker('duplicate_namespace_check')
        cls.ns = rospy.get_param('~ns').rstrip('/')
        cls.rounds = rospy.get_param('~rounds', 2)
        timeout = rospy.get_param('~timeout', 150.0)
        cls.lock = threading.Lock()
        cls.decisions = []
        rospy.Subscriber(cls.ns + '/decision', Decision, cls.on_decision,
                         queue_size=10)
        master = rosgraph.Master(rospy.get_name())
        deadline = time.time() + timeout
        cls.before = {}
        while time.time() < deadline and len(cls.before) < len(NODES):
            cls.before = pids(master, cls.ns)
            time.sleep(0.2)
        log = tempfile.NamedTemporaryFile(
            'w+', prefix='second_system_', suffix='.log', delete=False)
        second = subprocess.Popen(
            ['roslaunch', 'hri_sync', 'dance_off.launch',
             '__ns:=' + cls.ns, 'ntp_port:=%d' % rospy.get_param(
                 '~ntp_port'), 'dur:=3.0', 'rounds:=1', 'robot:=none',
             'music:=false'],
            stdout=log, stderr=subprocess.STDOUT, start_new_session=True)
        cls.second_exit = None
        while time.time() < deadline:
            cls.second_exit = second.poll()
            if cls.second_exit is not None:
                break
            time.sleep(0.2)
        if cls.second_exit is None:
            stop_group(second)
        log.seek(0)
        cls.second_output = log.read()
        os.unlink(log.name)
        cls.after_launch = pids(master, cls.ns)
        start = rospy.ServiceProxy(cls.ns + '/control_module/start_round',
                                   Trigger)
        cls.ends = []
        for _ in range(cls.rounds):
            try:
                start.wait_for_service(max(1.0, deadline - time.time()))
                cls.ends.append(start())
            except (rospy.ServiceException, rospy.ROSException) as e:
                cls.ends.append(e)
        while time.time() < deadline:
            with cls.lock:
                if len(cls.decisions) >= cls.rounds:
                    break
            time.sleep(0.2)
        cls.after = pids(master, cls.ns)

    @classmethod
    def on_decision(cls, msg):
        caller = msg._connection_header.get('callerid', '')
        with cls.lock:
            cls.decisions.append((caller, msg))

    def test_the_second_system_is_refused(self):
        self.assertIsNotNone(self.second_exit,
                             'the second launch did not end by itself')
        self.assertIn('a system already runs in %s/: node %s/'
                      % (self.ns, self.ns), self.second_output)
        self.assertIn('use another namespace', self.second_output)

    def test_the_running_system_keeps_its_nodes(self):
        self.assertEqual(len(self.before), len(NODES), self.before)
        self.assertEqual(self.after_launch, self.before)
        self.assertEqual(self.after, self.before)

    def test_the_running_system_decides_its_rounds(self):
        with self.lock:
            decisions = list(self.decisions)
        rounds = [d.round for _, d in decisions]
        self.assertEqual(len(rounds), self.rounds,
                         'rounds started: %s' % self.ends)
        self.assertEqual(len(rounds), len(set(rounds)),
                         'a round decided twice: %s' % rounds)
        for caller, d in decisions:
            self.assertEqual(caller, self.ns + '/decision_module')
            self.assertEqual(list(d.clients), ['left', 'right'])


if __name__ == '__main__':
    rostest.rosrun('hri_sync', 'duplicate_namespace', DuplicateNamespace)
