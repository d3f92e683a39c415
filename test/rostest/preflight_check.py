#!/usr/bin/python3
"""Runs ``rosrun hri_sync preflight ~args`` and checks its verdict: exit
status 0 (go) or 1 (no-go) as ~expect_go says, and every string of
~expect in its output."""
import subprocess
import sys
import unittest

import rospy

from hri_sync.ros.node import init_checker
import rostest


class PreflightCheck(unittest.TestCase):

    def test_verdict(self):
        args = rospy.get_param('~args').split()
        go = rospy.get_param('~expect_go')
        p = subprocess.run(['rosrun', 'hri_sync', 'preflight',
                            '__name:=preflight'] + args,
                           capture_output=True, text=True, timeout=90)
        out = p.stdout + p.stderr
        sys.stdout.write(out)
        self.assertEqual(p.returncode, 0 if go else 1, out)
        self.assertIn('preflight: ' + ('GO' if go else 'NO-GO'), out)
        for s in rospy.get_param('~expect', []):
            self.assertIn(s, out)


if __name__ == '__main__':
    init_checker('preflight_check')
    rostest.rosrun('hri_sync', 'preflight_check', PreflightCheck)
