#!/usr/bin/python3
"""Checks /diagnostics during a round (issue 13).

Every node of the round publishes its statuses: the CM (clock, rounds,
input), each CPM (clock, rounds, input: left and right's, and the robot's
dj_rob and music), whose input counts a forged sync_time its inbox
rejected, each DPM (clock, sensor, results, input) and the DM (clock,
decisions, input).  The synced clients' clocks are synced and their
rounds show the capture scheduled for round 1; left's DPM its sensor's
rate and its result; the CM shows the round captured with ~unreachable
refused, then decided; the DM the decision with ~unreachable's result
missing.  ~unreachable's time server (~ntp_server) does not answer: its
CPM's and DPM's clocks are ERROR naming it, its rounds the NACK.  The
aggregator (/diagnostics_agg) groups the statuses by client.  No time
bound is asserted: the checker waits for the round's decision, then for
the expected statuses, within generous deadlines.
"""
import threading
import time
import unittest

import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
from std_msgs.msg import Header

from hri_sync.msg import Decision, SyncTime
from hri_sync.ros.node import init_checker
from hri_sync.ros.timers import wait_for

SYNCED = ('left', 'dj_rob', 'music')
CPM_NODES = {'left': 'left/cpm', 'right': 'right/cpm', 'dj_rob': 'dj_rob',
             'music': 'music'}


class Seen:
    """Every status received, by name, as (level, message, values,
    hardware_id).  With ``nodes``, a node's statuses: diagnostic_updater's
    announcement of each task when the node adds it ('Node starting up',
    no values), which a checker up first sees, is left out."""

    def __init__(self, topic, nodes=False):
        self.lock = threading.Lock()
        self.by_name = {}
        self.nodes = nodes
        rospy.Subscriber(topic, DiagnosticArray, self.on_array,
                         queue_size=100)

    def on_array(self, msg):
        with self.lock:
            for s in msg.status:
                if self.nodes and not s.values:
                    continue
                self.by_name.setdefault(s.name, []).append(
                    (s.level, s.message, {kv.key: kv.value
                                          for kv in s.values},
                     s.hardware_id))

    def history(self, name):
        with self.lock:
            return list(self.by_name.get(name, []))

    def names(self):
        with self.lock:
            return sorted(self.by_name)


class DiagnosticsCheck(unittest.TestCase):
    """The statuses of every node during a round with an unsynced client."""

    @classmethod
    def setUpClass(cls):
        init_checker('diagnostics_check')
        cls.bad = rospy.get_param('~unreachable')
        cls.server = rospy.get_param('~ntp_server')
        cls.diag = Seen('/diagnostics', nodes=True)
        cls.agg = Seen('/diagnostics_agg')
        cls.decisions = []
        rospy.Subscriber('/decision', Decision, cls.decisions.append)
        ok = wait_for(lambda: any(d.round == 1 for d in cls.decisions), 90.0)
        assert ok, 'no decision of round 1 within 90 s'
        # The statuses published on the decision and the next periodic
        # ones (every 1 s).
        wait_for(lambda: any(s[2].get('last_outcome') == 'decided' for s in
                         cls.diag.history('control_module: rounds')), 10.0)
        # A forged sync_time (not from the CM): every CPM's inbox rejects
        # it and counts it on /diagnostics.
        forger = rospy.Publisher('/sync_time', SyncTime, queue_size=10)
        wait_for(lambda: forger.get_num_connections() >= len(CPM_NODES), 10.0)
        for _ in range(3):
            forger.publish(SyncTime(header=Header(stamp=rospy.Time(1)),
                                    round=7))
            time.sleep(0.2)
        # Every CPM's next periodic input status (1 s; later on a loaded
        # machine) counts it: wait for them, then one more period.
        wait_for(lambda: all(any(int(v.get('/sync_time wrong_sender', 0)) >= 1
                             for _, _, v, _ in cls.diag.history(
                                 node + ': input'))
                         for node in CPM_NODES.values()), 20.0)
        time.sleep(1.5)

    def seen(self, name, predicate, what):
        history = self.diag.history(name)
        self.assertTrue(history, 'no status %r on /diagnostics; seen: %s'
                        % (name, self.diag.names()))
        self.assertTrue(any(predicate(*s) for s in history),
                        '%s: no status %s; last: %s' % (name, what,
                                                        history[-1]))

    def test_every_cpm_publishes_clock_rounds_and_input(self):
        for client, node in CPM_NODES.items():
            for task in ('clock', 'rounds', 'input'):
                name = '%s: %s' % (node, task)
                self.seen(name, lambda level, msg, v, hw: hw == client,
                          'with hardware id %s' % client)
            self.seen(node + ': input',
                      lambda level, msg, v, hw: level == DiagnosticStatus.WARN
                      and int(v.get('/sync_time wrong_sender', 0)) >= 1
                      and int(v['rejected_total']) >= 1
                      and int(v.get('/sync_time accepted', 0)) >= 1,
                      'counting the forged sync_time')

    def test_synced_clients_are_synced_and_scheduled(self):
        for client in SYNCED:
            node = CPM_NODES[client]
            self.seen(node + ': clock',
                      lambda level, msg, v, hw: level != DiagnosticStatus.ERROR
                      and v['synced'] == 'true'
                      and float(v['uncertainty_ms'])
                      <= float(v['max_uncertainty_ms'])
                      and v['since_last_sync_s'] != 'never'
                      and v['drift_ppm'] != 'nan',
                      'synced within its limit')
            self.seen(node + ': rounds',
                      lambda level, msg, v, hw: level == DiagnosticStatus.OK
                      and v.get('last_round') == '1'
                      and v.get('last_outcome') == 'scheduled'
                      and v.get('late_count') == '0',
                      'with round 1 scheduled')

    def test_the_unreachable_client_says_error_and_why(self):
        node = CPM_NODES[self.bad]
        history = self.diag.history(node + ': clock')
        self.assertTrue(history, 'no clock status from %s' % node)
        level, message, values, _ = history[-1]
        self.assertEqual(level, DiagnosticStatus.ERROR, message)
        self.assertEqual(values['synced'], 'false')
        self.assertIn('not synced', message)
        self.assertIn('did not answer', message)
        self.assertIn(self.server, message)
        self.assertIn(self.server, values['last_error'])
        self.seen(node + ': rounds',
                  lambda level, msg, v, hw: level == DiagnosticStatus.WARN
                  and v['last_round'] == '1'
                  and v['last_outcome'] == 'nacked'
                  and self.server in v['last_reason'],
                  'with the NACK of round 1 and its reason')

    def test_every_cpm_and_the_cm_check_their_host_clock(self):
        # Issue 21, item 6: the system clock against the time server.
        for client in SYNCED:
            self.seen(CPM_NODES[client] + ': host_clock',
                      lambda level, msg, v, hw: hw == client
                      and v['system_clock_offset_ms'].endswith(' ms')
                      and v['model_offset_ms'].endswith(' ms')
                      and v['warn_above_ms'] == '5.0'
                      and 'chrony_offset_ms' in v
                      and 'off the time server (measured by SNTP)' in msg,
                      'with its SNTP-measured offset')
        self.seen('control_module: host_clock',
                  lambda level, msg, v, hw: 'measured by SNTP' in msg,
                  'with its SNTP-measured offset')
        history = self.diag.history(CPM_NODES[self.bad] + ': host_clock')
        self.assertTrue(history, 'no host_clock status from %s' % self.bad)
        level, message, values, _ = history[-1]
        self.assertEqual(values['system_clock_offset_ms'], 'n/a')
        self.assertIn(self.server, values['system_clock_error'])
        if values['chrony_offset_ms'].endswith(' ms'):    # a chronyd here
            self.assertIn('by chrony', message)
        else:
            self.assertEqual(level, DiagnosticStatus.ERROR, message)
            self.assertIn('system clock offset unknown: ', message)
            self.assertIn(self.server, message)

    def test_the_cm_shows_the_quorum_round_then_its_decision(self):
        self.seen('control_module: input',
                  lambda level, msg, v, hw: 'rejected_total' in v,
                  'counting rejected input')
        self.seen('control_module: clock',
                  lambda level, msg, v, hw: v['synced'] == 'true'
                  and level != DiagnosticStatus.ERROR and hw == 'server',
                  'synced')
        self.seen('control_module: rounds',
                  lambda level, msg, v, hw: v['last_round'] == '1'
                  and v['last_outcome'] == 'capturing'
                  and v['%s refused_count' % self.bad] == '1'
                  and v['left refused_count'] == '0',
                  'capturing round 1 without %s' % self.bad)
        self.seen('control_module: rounds',
                  lambda level, msg, v, hw: level == DiagnosticStatus.OK
                  and v['last_round'] == '1'
                  and v['last_outcome'] == 'decided'
                  and v['decided_count'] == '1',
                  'with round 1 decided')

    def test_the_dpms_show_clock_sensor_and_results(self):
        self.seen('left/dpm: clock',
                  lambda level, msg, v, hw: v['synced'] == 'true'
                  and level != DiagnosticStatus.ERROR and hw == 'left',
                  'synced')
        self.seen('left/dpm: sensor',
                  lambda level, msg, v, hw: level == DiagnosticStatus.OK
                  and float(v['rate_hz']) > 0
                  and v['topic'] == '/reference/samples',
                  'receiving its sensor')
        self.seen('left/dpm: results',
                  lambda level, msg, v, hw: v['last_round'] == '1'
                  and v['last_outcome'] in ('ok', 'partial')
                  and int(v['ok_count']) + int(v['partial_count']) == 1,
                  'with the result of round 1')
        self.seen('left/dpm: input',
                  lambda level, msg, v, hw: 'rejected_total' in v,
                  'counting refused samples')
        node = CPM_NODES[self.bad].replace('cpm', 'dpm')
        history = self.diag.history(node + ': clock')
        self.assertTrue(history, 'no clock status from %s' % node)
        level, message, values, _ = history[-1]
        self.assertEqual(level, DiagnosticStatus.ERROR, message)
        self.assertIn('not synced', message)
        self.assertIn(self.server, message)
        self.assertEqual(values['synced'], 'false')

    def test_the_dm_shows_the_decision_and_the_missing_result(self):
        self.seen('decision_module: clock',
                  lambda level, msg, v, hw: v['synced'] == 'true'
                  and level != DiagnosticStatus.ERROR and hw == 'server',
                  'synced')
        self.seen('decision_module: decisions',
                  lambda level, msg, v, hw: v['last_round'] == '1'
                  and v['last_outcome'] in ('winner', 'no_winner', 'tie')
                  and v['%s missing_count' % self.bad] == '1'
                  and v['left missing_count'] == '0'
                  and int(v['left ok_count'])
                  + int(v['left partial_count']) == 1,
                  'with round 1 decided without %s' % self.bad)
        self.seen('decision_module: input',
                  lambda level, msg, v, hw: 'rejected_total' in v,
                  'counting results not taken')

    def test_the_aggregator_groups_the_statuses_by_client(self):
        names = self.agg.names()
        for group in ('/Server', '/Clients/left', '/Clients/right',
                      '/Clients/dj_rob', '/Clients/music'):
            self.assertIn(group, names)
        self.assertIn('/Clients/left/left cpm: clock', names)
        self.assertIn('/Clients/left/left dpm: sensor', names)
        self.assertIn('/Server/decision_module: decisions', names)
        self.assertIn('/Clients/dj_rob/dj_rob: rounds', names)
        self.assertIn('/Server/control_module: rounds', names)
        self.assertNotIn('/Other', names)
        level = self.agg.history('/Clients/%s' % self.bad)[-1][0]
        self.assertEqual(level, DiagnosticStatus.ERROR)
        levels = [s[0] for s in self.agg.history('/Clients/left')]
        self.assertTrue(any(lv < DiagnosticStatus.ERROR for lv in levels),
                        'left is ERROR in every aggregate: %s' % levels)


if __name__ == '__main__':
    rostest.rosrun('hri_sync', 'diagnostics_round', DiagnosticsCheck)
