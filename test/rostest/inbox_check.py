#!/usr/bin/python3
"""Checks hri_sync.ros.inbox on a live graph (issue 11).

Two nodes publish /sync_time: /rightful (the CM by ~senders; every 4th
of its messages has the invalid round 0) and /forger (round 666, valid
otherwise).  Through an Inbox, only the rightful node's valid messages
reach the callback; the forger's are rejected as wrong_sender, the
invalid ones as round_invalid, both counted; a callback that raises on
every 3rd message is counted and keeps being called.
"""
import time
import unittest

import rospy
import rostest

from hri_sync.msg import SyncTime
from hri_sync.ros.inbox import Inbox
from hri_sync.ros.node import init_checker
from hri_sync.wire.validate import Context


class InboxCheck(unittest.TestCase):
    """Sender and content checks of a subscription."""

    def test_only_the_rightful_sender_gets_through(self):
        inbox = Inbox()
        seen = []

        def callback(msg):
            seen.append(msg.round)
            if len(seen) % 3 == 0:
                raise RuntimeError('callback failure %d' % len(seen))
        inbox.subscribe('/sync_time', SyncTime, callback, 'cm',
                        context=lambda: Context(now=time.time()))
        deadline = time.monotonic() + 60.0
        while time.monotonic() < deadline and not (
                len(seen) >= 30
                and inbox.rejected[('/sync_time', 'wrong_sender')] >= 30
                and inbox.rejected[('/sync_time', 'round_invalid')] >= 5):
            time.sleep(0.1)
        rospy.loginfo('inbox: %s', inbox.summary())
        self.assertEqual(set(seen), {1}, 'forged or invalid messages got '
                         'through: %s' % sorted(set(seen)))
        self.assertGreaterEqual(len(seen), 30)
        self.assertGreaterEqual(
            inbox.rejected[('/sync_time', 'wrong_sender')], 30)
        self.assertGreaterEqual(
            inbox.rejected[('/sync_time', 'round_invalid')], 5)
        self.assertEqual(inbox.errors[('/sync_time', 'RuntimeError')],
                         len(seen) // 3)
        self.assertEqual(inbox.accepted['/sync_time'], len(seen))


if __name__ == '__main__':
    init_checker('inbox_check')
    rostest.rosrun('hri_sync', 'inbox_check', InboxCheck)
