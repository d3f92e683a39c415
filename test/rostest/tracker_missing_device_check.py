#!/usr/bin/python3
"""Checks a client whose tracker names a sensor that does not exist (issue 13).

A tracker that gave up would exit (client.launch respawns it, and its
failed_opens count would start over).  Over ``~duration`` s:
every /diagnostics status of the tracker is an ERROR naming the device URI
and the retry, its failed_opens count goes up (it keeps retrying), no
skeleton is published, the CPM's ``dpm`` status (why it would NACK)
names the silent sensor and what the tracker said, and the tracker, CPM
and DPM still answer at the end.
"""
import time
import unittest

import rosnode
import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from hri_sync.msg import Skeleton
from hri_sync.ros.node import init_checker

PKG = 'hri_sync'


class TrackerMissingDeviceTest(unittest.TestCase):

    def test_names_the_device_and_keeps_retrying(self):
        client = rospy.get_param('~client_id')
        device = rospy.get_param('~device')
        statuses, skeletons, cpm = [], [], []
        # (diagnostic_updater announces each task once, with no values:
        # 'Node starting up'; a checker up first sees it)
        rospy.Subscriber('/diagnostics', DiagnosticArray,
                         lambda m: statuses.extend(
                             s for s in m.status
                             if s.name == client + '/tracker: sensor'
                             and s.values))
        rospy.Subscriber('/diagnostics', DiagnosticArray,
                         lambda m: cpm.extend(
                             s for s in m.status
                             if s.name == client + '/cpm: dpm'
                             and s.values))
        rospy.Subscriber('/%s/skeleton' % client, Skeleton,
                         lambda m: skeletons.append(m))
        deadline = time.time() + rospy.get_param('~duration')
        while time.time() < deadline and not rospy.is_shutdown():
            time.sleep(0.1)
        self.assertGreaterEqual(len(statuses), 3, 'no tracker diagnostics')
        for s in statuses:
            self.assertEqual(s.level, DiagnosticStatus.ERROR, s.message)
            self.assertIn("cannot open '%s'" % device, s.message)
            self.assertIn('retrying every', s.message)
            self.assertEqual(s.hardware_id, device)
        failed = [int(dict((v.key, v.value) for v in s.values)
                      ['failed_opens']) for s in statuses]
        self.assertGreater(failed[-1], failed[0],
                           'no new open attempt: %s' % failed)
        self.assertEqual(skeletons, [])
        said = [s for s in cpm if 'its driver said' in s.message]
        self.assertTrue(said, 'the CPM never said what the tracker said: %s'
                        % [s.message for s in cpm[-1:]])
        rospy.loginfo('the CPM: %s', said[-1].message)
        for s in said:
            self.assertEqual(s.level, DiagnosticStatus.ERROR, s.message)
            self.assertIn('sensor /%s/skeleton silent' % client, s.message)
            self.assertIn("ERROR cannot open '%s'" % device, s.message)
        for node in ('tracker', 'cpm', 'dpm'):
            name = '/%s/%s' % (client, node)
            self.assertTrue(rosnode.rosnode_ping(name, max_count=1),
                            '%s is not running' % name)


if __name__ == '__main__':
    init_checker('tracker_missing_device_check')
    rostest.rosrun(PKG, 'tracker_missing_device',
                   TrackerMissingDeviceTest)
