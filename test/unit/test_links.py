"""Subscriptions that missed a publisher (hri_sync.ros.links): the check's
rule, and rospy's lost publisher update reproduced on a real master."""
import os
import subprocess
import sys
import textwrap
import threading
import time

import pytest

from hri_sync.ros.links import LinkCheck
from hri_sync_support.harness import free_port, wait_for_master, wait_until

A, B = 'http://h:1/', 'http://h:2/'


def test_a_publisher_missing_at_two_checks_in_a_row_is_handed_over():
    check = LinkCheck(settle=30.0, first=1.0)
    assert check.due({'/t': 'T'}, 0.0) == ['/t']
    assert check.repair('/t', [A, B], [A], 0.0) == []     # may be under way
    assert check.repair('/t', [A, B], [A], 1.0) == [B]
    assert check.repairs == 1
    assert check.repair('/t', [A, B], [A, B], 2.0) == []
    assert check.due({'/t': 'T'}, 3.0) == []               # complete: done


def test_a_publisher_connected_between_two_checks_is_not_handed_over():
    check = LinkCheck()
    check.due({'/t': 'T'}, 0.0)
    check.repair('/t', [A], [], 0.0)
    assert check.repair('/t', [A, B], [A], 1.0) == []      # B is new
    assert check.repairs == 0


def test_complete_before_first_is_checked_again_and_checks_end_at_settle():
    check = LinkCheck(settle=10.0, first=1.0)
    check.due({'/t': 'T', '/u': 'U'}, 0.0)
    check.repair('/t', [], [], 0.5)          # too early to call complete
    assert check.due({'/t': 'T', '/u': 'U'}, 0.9) == ['/t', '/u']
    assert check.due({'/t': 'T', '/u': 'U'}, 10.0) == []


def test_a_subscription_made_again_is_checked_again():
    check = LinkCheck()
    check.due({'/t': 'T'}, 0.0)
    check.repair('/t', [A], [A], 2.0)
    assert check.due({'/t': 'T'}, 3.0) == []
    assert check.due({}, 4.0) == []
    assert check.due({'/t': 'T'}, 5.0) == ['/t']


SUBSCRIBER = textwrap.dedent('''
    import sys, time
    import rospy
    from rospy.impl.registration import RegManager
    from std_msgs.msg import String
    from hri_sync.ros.node import run_node

    # The end of rospy's race, made certain: the last publisher list queued
    # for the topic is registerSubscriber's answer without the publisher,
    # though the master had it (its update, with it, was dropped).
    update = RegManager.publisher_update
    def stale(self, topic, uris):
        if topic == '/chatter' and not stale.done:
            stale.done, uris = True, []
        update(self, topic, uris)
    stale.done = False
    RegManager.publisher_update = stale

    def main():
        got = []
        rospy.Subscriber('/chatter', String, got.append)
        deadline = time.monotonic() + 60
        while not got and time.monotonic() < deadline:
            time.sleep(0.05)
        print('received' if got else 'nothing', stale.done, flush=True)
    run_node('listener', main)
''')

PUBLISHER = textwrap.dedent('''
    import rospy
    from std_msgs.msg import String
    rospy.init_node('talker')
    pub = rospy.Publisher('/chatter', String, queue_size=1, latch=True)
    pub.publish('hello')
    print('published', flush=True)
    rospy.spin()
''')


@pytest.mark.skipif(not os.path.exists('/usr/bin/rosmaster'),
                    reason='needs ROS (rosmaster)')
def test_a_lost_publisher_update_is_repaired(tmp_path):
    port = free_port()
    env = dict(os.environ, ROS_MASTER_URI='http://127.0.0.1:%d' % port,
               ROS_HOME=str(tmp_path), PYTHONPATH=os.pathsep.join(sys.path))
    procs = [subprocess.Popen(['/usr/bin/rosmaster', '--core', '-p',
                               str(port)], env=env,
                              stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL)]
    try:
        # Up before the talker: the talker's own XML-RPC server once took
        # the port first (make test-load), and registered with itself.
        wait_for_master(env['ROS_MASTER_URI'], 60, [('rosmaster', procs[0])])
        talker = subprocess.Popen(['/usr/bin/python3', '-c', PUBLISHER],
                                  env=env, stdout=subprocess.PIPE,
                                  stderr=subprocess.DEVNULL, text=True)
        procs.append(talker)
        # (rospy says on stdout while it waits for the master)
        lines = []
        threading.Thread(target=lambda: [lines.append(line.strip())
                                         for line in talker.stdout],
                         daemon=True).start()
        wait_until('the talker to publish', lambda: 'published' in lines,
                   120, [('the talker', talker)])
        listener = subprocess.Popen(
            ['/usr/bin/python3', '-c', SUBSCRIBER], env=env,
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        procs.append(listener)
        out, err = listener.communicate(timeout=120)
        assert out.strip() == 'received True', err
        assert 'not connected to' in err and '/chatter' in err
    finally:
        for p in procs:
            p.kill()
            p.wait()


class FakeTopics:
    """rospy's topic manager, as LinkRepair reads it."""

    def __init__(self, subscribed, impls):
        self.subscribed = subscribed
        self.impls = impls

    def get_subscriptions(self):
        return [[t, 'std_msgs/String'] for t in self.subscribed]

    def get_subscriber_impl(self, topic):
        return self.impls.get(topic)


def test_a_subscription_gone_during_the_check_is_unregistered_again(
        monkeypatch):
    from hri_sync.ros import links
    calls = []

    def call(method, *args):
        calls.append((method,) + args)
        return 1, '', []
    monkeypatch.setattr(links, 'get_topic_manager',
                        lambda: FakeTopics(['/gone'], {}))
    monkeypatch.setattr(links.rospy, 'get_node_uri', lambda: A)
    links.LinkRepair(call).check()
    assert calls == [
        ('registerSubscriber', '/gone', 'std_msgs/String', A),
        ('unregisterSubscriber', '/gone', A)]
