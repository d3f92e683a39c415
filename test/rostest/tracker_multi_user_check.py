#!/usr/bin/python3
"""Checks skeleton_tracker with several people in view (issue 18 item 3).

Three people in the virtual Kinect's view: once calibrated, /diagnostics
says how many users it tracks (``tracked_users`` = 3, message "tracking 3
users", ``tracked_user_ids`` naming them, ``user_bodies`` their calibrated
heights and girths), never more than are in view;
skeletons arrive under that many distinct ``user_id`` values, each id's
torso staying in one place (the people do not swap ids).
"""
import time
import unittest

import rospy

from hri_sync.ros.node import init_checker
import rostest

from tracker_partial_view_check import listen

PKG = 'hri_sync'
TORSO = 2


class _Values:
    """The statuses as dicts of their values (and 'message'), read live."""

    def __init__(self, statuses):
        self.statuses = statuses

    def __iter__(self):
        for s in list(self.statuses):
            yield dict([('message', s.message)] +
                       [(kv.key, kv.value) for kv in s.values])


class TrackerMultiUserTest(unittest.TestCase):

    def test_every_user_published_and_counted(self):
        client = rospy.get_param('~client_id')
        people = int(rospy.get_param('~people'))
        statuses, skeletons = listen(client)
        diags = _Values(statuses)
        deadline = time.time() + 60.0
        while time.time() < deadline and not rospy.is_shutdown() and not [
                d for d in diags
                if d.get('tracked_users') == str(people)
                and d.get('global_clock') == 'ok']:
            time.sleep(0.1)
        end = time.time() + rospy.get_param('~duration', 6.0)
        while time.time() < end and not rospy.is_shutdown():
            time.sleep(0.1)
        counts = [int(d.get('tracked_users', -1)) for d in diags]
        full = [d for d in diags if d.get('tracked_users') == str(people)
                and d.get('global_clock') == 'ok']
        self.assertTrue(full, 'never %d users: %s' % (people, counts))
        self.assertEqual(full[0]['message'], 'tracking %d users' % people)
        self.assertEqual(len(full[0]['tracked_user_ids'].split()), people)
        # Each calibrated user's body model: "1: 1.72 m, girth 1.04; ...".
        bodies = full[-1]['user_bodies'].split('; ')
        self.assertGreaterEqual(len(bodies), people, bodies)
        for body in bodies:
            _, rest = body.split(': ')
            height, girth = rest.split(' m, girth ')
            self.assertTrue(1.2 <= float(height) <= 2.2, body)
            self.assertTrue(0.5 <= float(girth) <= 2.0, body)
        self.assertLessEqual(max(counts), people, counts)
        for d in diags:
            self.assertIn('people_in_view', d)
            self.assertEqual(d['max_users'], '4')
        ids = sorted(set(m.user_id for m in skeletons))
        self.assertGreaterEqual(len(ids), people, ids)
        # Each id stays on one person: from one frame to the next (0.1 s;
        # a user lost for longer may come back elsewhere, within its gate,
        # e.g. when the looping motion moves the dancer back to its start)
        # its torso never jumps to another person 1.3 m away.
        last = {}
        for m in skeletons:
            p, t = m.positions[TORSO], m.header.stamp.to_sec()
            if m.user_id in last and t - last[m.user_id][1] < 0.1:
                q = last[m.user_id][0]
                self.assertLess(abs(p.x - q.x) + abs(p.z - q.z), 0.8,
                                'user %d jumped' % m.user_id)
            last[m.user_id] = (p, t)


if __name__ == '__main__':
    init_checker('tracker_multi_user_check')
    rostest.rosrun(PKG, 'tracker_multi_user', TrackerMultiUserTest)
