#!/usr/bin/python3
"""Fuzzes a running dance-off (issue 11, item 5).

Starts ``dance_off.launch rounds:=0`` (rounds on the CM's ~start_round
service) on this test's master, with its screen output in a file, and:

1. runs a clean round, which must be decided (the setup works), then
   another while each participant's CPM's caller id sends its DPM
   ~forged capture commands for round 2**32 - 1 (a skeleton DPM once
   started capturing such a round): that round must be decided as the
   DPMs' results give, each DPM must publish no result of round
   2**32 - 1 and count every forged command on /diagnostics
   (``<id>/dpm: input``, ``/<id>/capture_command unscheduled_round``);
2. runs a round while test/rostest/fuzz_publisher.py publishes ~count seeded
   random-field messages on every topic the nodes subscribe to, under
   its own caller id or, with ~impersonate, under each topic's rightful
   owner's;
3. checks every node of the launch is still alive (registered and
   answering a ping);
4. runs another clean round: it must end in the decision that
   hri_sync.decision.rule.decide gives on the two DPMs' own results
   (by caller id), both ok, by the decision module's rule;
   ~impersonate may be a list: steps 2-4 then run once for each item,
   on the same launch;
5. checks no traceback through this package's code was logged: neither
   in the launch's output nor in the nodes' log files.  A traceback with
   no frame of ours is rospy's own transport thread losing a peer (the
   fuzzer's connections closing mid-handshake on a loaded machine:
   ROSHandshakeException, a socket already closed); rospy logs it and
   goes on, so it is reported but not counted.

What broke is logged per node (dead nodes, tracebacks by log file).
"""
import collections
import glob
import os
import re
import signal
import subprocess
import tempfile
import threading
import time
import unittest

import rosnode
import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray
from std_msgs.msg import Header
from std_srvs.srv import Trigger

from hri_sync.msg import (CaptureCommand, ClientResult, ClockState, Decision,
                          DpmState)
from hri_sync.ros.node import init_checker
from hri_sync.ros.timers import wait_for
from hri_sync.decision.rule import decide

# The dance-off's; ~clients and ~participants for another ~launch.
CLIENTS = ('left', 'right', 'dj_rob', 'music')
PARTICIPANTS = ('left', 'right')
FORGED_ROUND = 2 ** 32 - 1
FRAME = re.compile(r'File "[^"]*/(?:nodes|lib/hri_sync)/(\w+)"|'
                   r'File "[^"]*/src/hri_sync/([\w/]+)\.py"')


def callerid(msg):
    return getattr(msg, '_connection_header', {}).get('callerid', '')


def tracebacks(paths):
    """{path: [(where, exception line)]} of the tracebacks in the files.

    ``where`` is the innermost frame in nodes/ (the node), else in
    hri_sync (a module); a traceback chained into a later one (``During
    handling ...``) counts once, as the later one.
    """
    out = {}
    for path in paths:
        try:
            with open(path, errors='replace') as f:
                lines = f.read().splitlines()
        except OSError:
            continue
        found = []
        for i, line in enumerate(lines):
            if 'Traceback (most recent call last)' not in line:
                continue
            nodes, modules, error, end = [], [], '?', len(lines)
            for j in range(i + 1, min(i + 80, len(lines))):
                m = FRAME.search(lines[j])
                if m:
                    (nodes if m.group(1) else modules).append(
                        m.group(1) or m.group(2))
                elif lines[j] and not lines[j][0].isspace():
                    error, end = lines[j].strip()[:160], j
                    break
            after = [x for x in lines[end + 1:end + 3] if x.strip()]
            if after and after[0].startswith(('During handling',
                                              'The above exception')):
                continue
            found.append(((nodes or modules or ['?'])[-1], error))
        if found:
            out[path] = found
    return out


def deaths(path):
    """Lines where roslaunch reports a process that died."""
    with open(path, errors='replace') as f:
        return [line.strip()[:200] for line in f
                if 'process has died' in line or 'has died!' in line]


class FuzzDanceOff(unittest.TestCase):
    """A fuzzed dance-off keeps its nodes and decides the next round."""

    def setUp(self):
        self.lock = threading.Lock()
        self.results, self.decisions, self.synced = [], [], set()
        self.fed = set()
        self.inputs = {}        # '<id>/dpm' -> its last input status values
        rospy.Subscriber('/client_result', ClientResult, self.keep,
                         self.results)
        rospy.Subscriber('/decision', Decision, self.keep, self.decisions)
        self.clients = rospy.get_param('~clients', list(CLIENTS))
        self.participants = rospy.get_param('~participants',
                                            list(PARTICIPANTS))
        for c in self.clients:
            rospy.Subscriber('/%s/clock_state' % c, ClockState,
                             self.on_clock, c)
        for c in self.participants:
            rospy.Subscriber('/%s/dpm_state' % c, DpmState, self.on_state,
                             c)
        # The launch's output and its nodes' logs, in a folder of ours.
        self.log_dir = tempfile.mkdtemp(prefix='fuzz_dance_off_')
        self.out = open(os.path.join(self.log_dir, 'launch.log'), 'w')
        launch = rospy.get_param('~launch', 'dance_off.launch')
        where = [] if os.path.isabs(launch) else ['hri_sync']
        self.launch = subprocess.Popen(
            ['roslaunch'] + where + [
                launch, 'rounds:=0',
                'dur:=%s' % rospy.get_param('~dur', 5.0),
                'ntp_port:=%d' % rospy.get_param('~ntp_port')]
            + rospy.get_param('~launch_args', [
                'left_seed:=4', 'right_seed:=21',
                'monitor_required:=false']),
            stdout=self.out, stderr=subprocess.STDOUT,
            start_new_session=True,
            env=dict(os.environ, ROS_LOG_DIR=self.log_dir))

    def tearDown(self):
        try:
            os.killpg(self.launch.pid, signal.SIGINT)
            self.launch.wait(timeout=30)
        except subprocess.TimeoutExpired:
            os.killpg(self.launch.pid, signal.SIGKILL)
            self.launch.wait()
        except ProcessLookupError:
            pass
        self.out.close()

    def keep(self, msg, into):
        with self.lock:
            into.append((time.time(), callerid(msg), msg))

    def on_clock(self, msg, client):
        if msg.ok and callerid(msg) != '/fuzz_publisher':
            self.synced.add(client)

    def on_state(self, msg, client):
        if msg.samples > 0 and callerid(msg) == '/%s/dpm' % client:
            self.fed.add(client)

    def on_diagnostics(self, msg):
        with self.lock:
            for s in msg.status:
                node, _, task = s.name.partition(': ')
                if task == 'input' and node.endswith('/dpm'):
                    self.inputs[node] = {kv.key: kv.value for kv in s.values}

    def start_round(self):
        """Call ~start_round in a thread; returns (thread, reply list)."""
        reply = []
        start = rospy.ServiceProxy('/control_module/start_round', Trigger)
        thread = threading.Thread(target=lambda: reply.append(start()),
                                  daemon=True)
        thread.start()
        return thread, reply

    def clean_round(self, name):
        """Run a round and return the DM's last decision since it started
        and the DPMs' results of that decision's round ({client: result})."""
        t0 = time.time()
        thread, reply = self.start_round()
        thread.join(rospy.get_param('~dur', 5.0) + 60.0)
        self.assertTrue(reply, '%s round: ~start_round did not return'
                        % name)
        rospy.loginfo('%s round: %s', name, reply[0].message)

        def mine(items, senders):
            with self.lock:
                return [m for t, c, m in items if t >= t0 and c in senders]
        dpms = {'/%s/dpm' % c for c in self.participants}

        def decided():
            """The last decision and its round's results by client."""
            decisions = mine(self.decisions, {'/decision_module'})
            if not decisions:
                return None, {}
            return decisions[-1], {
                m.client_id: m for m in mine(self.results, dpms)
                if m.round == decisions[-1].round}
        # Every result comes before its decision, but on a connection of
        # its own: a loaded checker may read it after.  Wait for both, by
        # round: a forged round's window (the fuzzer's capture commands)
        # can end inside this one, and its result come in first.
        wait_for(lambda: decided()[0] and set(decided()[1]) >= set(
            self.participants), 10.0)
        decision, results = decided()
        self.assertTrue(decision, '%s round: no decision from the DM' % name)
        return decision, results

    def nodes(self):
        return set(rosnode.get_node_names()) - {
            rospy.get_name(), '/rosout', '/fuzz_publisher'}

    def test_fuzzed_dance_off(self):
        self.assertTrue(wait_for(lambda: self.synced >= set(self.clients),
                                 90.0),
                        'clients never synced: %s' % sorted(self.synced))
        # A loaded machine can start a sensor late: the first round waits
        # for every DPM's heartbeat to report a sample, as an operator would.
        self.assertTrue(wait_for(lambda: self.fed >= set(self.participants),
                                 60.0),
                        'sensors never delivered: only %s' % sorted(self.fed))
        rospy.wait_for_service('/control_module/start_round', 30.0)
        decision, _ = self.clean_round('first clean')
        self.assertNotEqual(decision.outcome, Decision.ABORTED,
                            decision.reason)
        self.assertEqual(self.forged_round(), [])
        before = self.nodes()
        rospy.loginfo('nodes before fuzzing: %s; logs in %s', sorted(before),
                      self.log_dir)

        failures = []
        passes = rospy.get_param('~impersonate', False)
        for impersonate in passes if isinstance(passes, list) else [passes]:
            failures += self.fuzz_pass(impersonate, before)
        self.out.flush()
        for line in deaths(self.out.name):
            rospy.loginfo('roslaunch: %s', line)
        found = tracebacks([self.out.name] + sorted({
            os.path.realpath(p) for p in glob.glob(
                os.path.join(self.log_dir, '*', '*.log'))}))
        for path, blocks in sorted(found.items()):
            for (where, error), n in sorted(
                    collections.Counter(blocks).items()):
                rospy.loginfo('%4d traceback(s) in %s: %s: %s', n,
                              os.path.basename(path), where, error)
        ours = sum(1 for blocks in found.values()
                   for where, _ in blocks if where != '?')
        if ours:
            failures.append('%d tracebacks logged' % ours)
        self.assertEqual(failures, [])

    def forged_round(self):
        """A clean round while each participant's DPM gets ~forged capture
        commands of round 2**32 - 1 under its CPM's caller id; returns
        what failed."""
        n = rospy.get_param('~forged', 3)
        # Only for this round: the fuzzer would fuzz a topic it subscribes.
        diagnostics = rospy.Subscriber('/diagnostics', DiagnosticArray,
                                       self.on_diagnostics, queue_size=100)
        pubs = {c: rospy.Publisher(
            '/%s/capture_command' % c, CaptureCommand, queue_size=10,
            headers={'callerid': '/%s/cpm' % c}) for c in self.participants}
        self.assertTrue(wait_for(lambda: all(
            p.get_num_connections() for p in pubs.values()), 30.0),
            'the DPMs never subscribed the forged capture_command')

        def forge():
            time.sleep(0.5)                 # the round under way
            for k in range(n):
                start = time.time() + 0.5   # global, within the DPM's bounds
                for p in pubs.values():
                    p.publish(CaptureCommand(
                        header=Header(stamp=rospy.Time.from_sec(time.time())),
                        round=FORGED_ROUND, start=rospy.Time.from_sec(start),
                        end=rospy.Time.from_sec(start + 1.0 + k)))
                time.sleep(0.5)
        threading.Thread(target=forge, daemon=True).start()
        t0 = time.time()
        decision, results = self.clean_round('forged commands')
        failures = self.check_decision(decision, results)
        key = '/%s/capture_command unscheduled_round'

        def counted():
            with self.lock:
                return {c: self.inputs.get('%s/dpm' % c, {}).get(key % c)
                        for c in self.participants}
        # Rejected ~order_wait (5 s) after each arrives, then on the next
        # /diagnostics (1 s).
        wait_for(lambda: all(v == str(n) for v in counted().values()), 30.0)
        diagnostics.unregister()
        rospy.loginfo('forged commands counted: %s', counted())
        failures += ['%s/dpm counted %s of %d forged commands as %s'
                     % (c, v, n, key % c) for c, v in counted().items()
                     if v != str(n)]
        with self.lock:
            forged = sorted({c for t, c, m in self.results
                             if t >= t0 and m.round == FORGED_ROUND})
        if forged:
            failures.append('results of round %d from %s'
                            % (FORGED_ROUND, forged))
        return failures

    def fuzz_pass(self, impersonate, before):
        """Fuzz a round (as its senders, with ``impersonate``), then check
        the nodes and a clean round; returns what failed."""
        name = 'impersonated' if impersonate else 'own caller id'
        rospy.loginfo('fuzzing (%s)', name)
        thread, _ = self.start_round()
        fuzz = subprocess.run(
            ['rosrun', 'hri_sync', 'fuzz_publisher.py',
             '_seed:=%d' % rospy.get_param('~seed', 1),
             '_count:=%d' % rospy.get_param('~count', 1000),
             '_rate:=%f' % rospy.get_param('~rate', 400.0),
             '_impersonate:=%s' % impersonate],
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
            timeout=rospy.get_param('~fuzz_timeout', 600.0))
        rospy.loginfo('fuzzer: %s', fuzz.stdout.strip().splitlines()[-1:])
        self.assertEqual(fuzz.returncode, 0, fuzz.stdout[-2000:])
        thread.join(60.0)

        after = self.nodes()
        dead = sorted(before - after)
        silent = sorted(n for n in after
                        if not rosnode.rosnode_ping(n, max_count=1))
        rospy.loginfo('after fuzzing (%s): dead %s, not answering %s', name,
                      dead, silent)
        failures = []
        try:
            decision, results = self.clean_round(
                'clean after fuzzing (%s)' % name)
            failures += self.check_decision(decision, results)
        except AssertionError as e:
            failures.append(str(e))
        if dead:
            failures.append('nodes died fuzzed (%s): %s' % (name, dead))
        if silent:
            failures.append('nodes not answering fuzzed (%s): %s'
                            % (name, silent))
        return failures

    def check_decision(self, decision, results):
        """What is wrong with a clean round's decision and results."""
        wrong = ['no ok result of %s from its DPM (%s)'
                 % (c, results[c].status if c in results else 'none')
                 for c in self.participants
                 if c not in results or results[c].status != ClientResult.OK]
        if wrong:
            return wrong
        want = decide(list(self.participants),
                      {c: (r.status, r.value, r.noise_floor, r.noise_source)
                       for c, r in results.items()},
                      rospy.get_param('~min_expressiveness', 1.0),
                      rospy.get_param('~tie_margin', 0.0), 'partial',
                      rospy.get_param('/decision_module/decision_rule'),
                      rospy.get_param('/decision_module/noise_factor'))
        if (decision.outcome, decision.winner) != (want.outcome,
                                                   want.winner):
            return ['decision %s %d (%s), the results give %s %d'
                    % (decision.outcome, decision.winner, decision.reason,
                       want.outcome, want.winner)]
        return []


if __name__ == '__main__':
    init_checker('fuzz_dance_off_check')
    rostest.rosrun('hri_sync', 'fuzz_dance_off', FuzzDanceOff)
