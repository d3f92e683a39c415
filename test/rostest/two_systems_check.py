#!/usr/bin/python3
"""Checks two dance-off systems on one master (test/rostest/two_systems.test).

Each system (a namespace: ~expect maps it to the participant that must
win) runs while the other does.  Checks:
- every node but this one and /rosout is in one of the systems'
  namespaces, and every topic too, except the global /diagnostics,
  /rosout, /rosout_agg, /tf and /tf_static;
- each system decides each of its ~rounds for its own winner, over its
  own clients (left, right), with a finite score for each; its clients
  (and, in ~robot_systems, DJ Rob and the music) ACK its last round and
  its two sensor clients report results for it;
- every message of a system's protocol topics (sync_time, sync_ack,
  capture_data, client_result, decision) was published by that
  system's own node (the connection header's caller id): no crossed
  rounds (the last round's messages are surely seen: the checker
  listens by then);
- a system's recorder (lab1 records) subscribes only to its own topics;
- in ~robot_systems, DJ Rob's dance start comes from the system's own
  dj_rob and its odometry from its own kobuki_sim;
- each system's tf frames carry its own prefix (``<system>/``): its
  skeletons' frame ids and its static transforms world -> sensor.
"""
import math
import threading
import time
import unittest

import rosgraph
import rospy
import rostest
from tf2_msgs.msg import TFMessage

from nav_msgs.msg import Odometry

from hri_sync.msg import (ActionStart, CaptureData, ClientResult, Decision,
                          Skeleton, SyncAck, SyncTime)
from hri_sync.ros.node import init_checker

GLOBAL = {'/diagnostics', '/rosout', '/rosout_agg', '/tf', '/tf_static'}
CLIENTS = ('left', 'right')
# The node that may publish each protocol topic, relative to the system.
OWNERS = {
    'sync_time': lambda m: {'control_module'},
    'capture_data': lambda m: {'control_module'},
    # a client's CPM, or a node that is the whole client (dj_rob, music)
    'sync_ack': lambda m: {m.client_id + '/cpm', m.client_id},
    'client_result': lambda m: {m.client_id + '/dpm', m.client_id + '/cpm'},
    'decision': lambda m: {'decision_module'},
}
TYPES = {'sync_time': SyncTime, 'capture_data': CaptureData,
         'sync_ack': SyncAck, 'client_result': ClientResult,
         'decision': Decision, 'dj_rob/action_start': ActionStart,
         'odom': Odometry}
ROBOT_OWNERS = {'dj_rob/action_start': 'dj_rob', 'odom': 'kobuki_sim'}


class TwoSystems(unittest.TestCase):
    """Two systems, each deciding on its own."""

    @classmethod
    def setUpClass(cls):
        init_checker('two_systems_check')
        cls.expect = rospy.get_param('~expect')
        cls.robots = rospy.get_param('~robot_systems', [])
        cls.rounds = rospy.get_param('~rounds', 2)
        timeout = rospy.get_param('~timeout', 150.0)
        cls.lock = threading.Lock()
        cls.seen = {s: {t: [] for t in TYPES} for s in cls.expect}
        for system in cls.expect:
            for topic, cls_ in TYPES.items():
                rospy.Subscriber('/%s/%s' % (system, topic), cls_,
                                 cls.on_message, (system, topic),
                                 queue_size=100)
        cls.frames = {}     # (system, client) -> skeleton frame ids
        cls.static = set()  # (parent, child) on /tf_static
        for system in cls.expect:
            for c in CLIENTS:
                rospy.Subscriber('/%s/%s/skeleton' % (system, c), Skeleton,
                                 cls.on_skeleton, (system, c))
        rospy.Subscriber('/tf_static', TFMessage, cls.on_tf_static,
                         queue_size=100)
        cls.master = rosgraph.Master(rospy.get_name())
        cls.state = None
        deadline = time.time() + timeout
        while not rospy.is_shutdown() and time.time() < deadline:
            with cls.lock:
                if all(any(m.round >= cls.rounds
                           for _, m in cls.seen[s]['decision'])
                       for s in cls.expect):
                    break
            if cls.state is None and cls.all_up():
                cls.state = cls.master.getSystemState()
            time.sleep(0.2)
        time.sleep(1.0)     # results come on connections of their own

    @classmethod
    def all_up(cls):
        """True once every system's CM, DM, clients and recorder are
        registered (the graph to check)."""
        pubs, subs, _ = cls.master.getSystemState()
        names = {n for _, ns in pubs + subs for n in ns}
        need = {'/%s/%s' % (s, n) for s in cls.expect
                for n in ('control_module', 'decision_module', 'left/cpm',
                          'left/dpm', 'right/cpm', 'right/dpm',
                          'left/sensor', 'right/sensor')}
        need.add('/lab1/recorder')
        return need <= names

    @classmethod
    def on_message(cls, msg, args):
        system, topic = args
        caller = msg._connection_header.get('callerid', '')
        with cls.lock:
            if len(cls.seen[system][topic]) < 1000:
                cls.seen[system][topic].append((caller, msg))

    @classmethod
    def on_skeleton(cls, msg, key):
        with cls.lock:
            cls.frames.setdefault(key, set()).add(msg.header.frame_id)

    @classmethod
    def on_tf_static(cls, msg):
        with cls.lock:
            cls.static.update((t.header.frame_id, t.child_frame_id)
                              for t in msg.transforms)

    def test_frames_are_prefixed(self):
        with self.lock:
            frames, static = dict(self.frames), set(self.static)
        for system in self.expect:
            for c in CLIENTS:
                self.assertEqual(frames.get((system, c)),
                                 {'%s/%s_sensor' % (system, c)})
                self.assertIn(('%s/world' % system,
                               '%s/%s_sensor' % (system, c)), static)

    def test_graph_is_namespaced(self):
        self.assertIsNotNone(self.state, 'the systems never came up')
        pubs, subs, _ = self.state
        prefixes = tuple('/%s/' % s for s in self.expect)
        for topic, nodes in pubs + subs:
            if topic not in GLOBAL:
                self.assertTrue(topic.startswith(prefixes),
                                'a topic outside the systems: %s (%s)'
                                % (topic, ', '.join(nodes)))
            for node in nodes:
                if node not in (rospy.get_name(), '/rosout'):
                    self.assertTrue(node.startswith(prefixes),
                                    'a node outside the systems: %s (on %s)'
                                    % (node, topic))

    def test_recorder_records_its_own_system(self):
        self.assertIsNotNone(self.state, 'the systems never came up')
        _, subs, _ = self.state
        recorded = sorted(t for t, nodes in subs
                          if '/lab1/recorder' in nodes)
        for topic in ('sync_time', 'sync_ack', 'capture_data',
                      'round_status', 'client_result', 'decision',
                      'server/clock_state', 'left/captured',
                      'right/clock_state', 'right/capture_command'):
            self.assertIn('/lab1/' + topic, recorded)
        for topic in recorded:
            self.assertTrue(topic.startswith('/lab1/'),
                            'lab1 records %s' % topic)

    def test_each_system_decides_for_its_own_dancer(self):
        for system, winner in self.expect.items():
            with self.lock:
                decisions = [m for _, m in self.seen[system]['decision']]
            self.assertIn(self.rounds, [d.round for d in decisions],
                          '%s: no decision of round %d' % (system,
                                                           self.rounds))
            for d in decisions:
                self.assertEqual(d.outcome, Decision.WINNER, '%s: %s (%s)'
                                 % (system, d.outcome, d.reason))
                self.assertEqual(d.winner, winner, '%s: %s' % (system, d))
                self.assertEqual(tuple(d.clients), CLIENTS)
                self.assertTrue(all(math.isfinite(s) for s in d.scores),
                                '%s: %s' % (system, d.scores))

    def test_messages_come_from_their_own_system(self):
        for system in self.expect:
            with self.lock:
                seen = {t: list(m) for t, m in self.seen[system].items()}
            for topic in ('sync_time', 'sync_ack', 'capture_data',
                          'client_result', 'decision'):
                self.assertTrue(seen[topic], '%s/%s: nothing' % (system,
                                                                 topic))
                for caller, msg in seen[topic]:
                    allowed = {'/%s/%s' % (system, n)
                               for n in OWNERS[topic](msg)}
                    self.assertIn(caller, allowed, '%s/%s from %s' % (
                        system, topic, caller))
            results = {m.client_id for _, m in seen['client_result']
                       if m.round == self.rounds}
            self.assertEqual(results, set(CLIENTS), system)
            acks = {m.client_id for _, m in seen['sync_ack']
                    if m.round == self.rounds}
            robot = system in self.robots
            self.assertEqual(acks, set(CLIENTS) | (
                {'dj_rob', 'music'} if robot else set()), system)
            for topic, owner in ROBOT_OWNERS.items():
                if not robot:
                    self.assertFalse(seen[topic], '%s/%s' % (system, topic))
                    continue
                self.assertTrue(seen[topic], '%s/%s: nothing' % (system,
                                                                 topic))
                for caller, _ in seen[topic]:
                    self.assertEqual(caller, '/%s/%s' % (system, owner))


if __name__ == '__main__':
    rostest.rosrun('hri_sync', 'two_systems', TwoSystems)
