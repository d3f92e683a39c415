#!/usr/bin/python3
"""Checks one dance-off round run by test/rostest/dance_off_round.launch.

Listens to /client_result, /decision and both /<client_id>/captured
streams and, after the round, checks:
- the decision is ~expect (no_winner, participant1, participant2 or
  aborted), over the clients left and right, with scores equal to the
  usable results' values (NaN for a result without data);
- a client whose result is not usable (~expect_status_<client> no_data)
  is named in the decision's reason;
- each result: status ~expect_status_<client> (default ok; partial when
  a loaded sensor itself sent less than the window needs), frames and
  coverage fitting a ~rate Hz sensor over DUR (a silent sensor: partial
  coverage below 1 and the decision says the result was partial), first
  frame within one sensor period of the start, a finite score, and as many
  captured frames republished as the DPM used plus rejected;
- scores against ~min_expressiveness: below for a still person, above for
  a mover;
- with ~nan_joints > 0: NaN joints were counted and the score stays finite;
- with ~drop > 0: each DPM saw gaps (frames_dropped > 0);
- ~expect_diagnostics ('client:key>value;client:key=value'): a result's
  field (frames_dropped...) or diagnostic compared with a number;
- ~expect_status_text ('<status name>=<text>;...'): a /diagnostics status
  (e.g. 'left/dpm: results') whose message or a value contains the text;
- with ~verify: records the round with rosbag, then runs verify_decisions
  on the bag, which must exit 0 and recompute the recorded decision;
- with ~bag_start (client=bag;...): each of those clients' results
  scores its bag's first DUR s, within 3 % (the replay started over at
  the window, ~replay_from window, whatever the start-up took);
- with ~calibration > 0: the calibration window before the round was
  answered with no winner on /calibration/decision, and every usable
  result whose client calibrated (an ok calibration result) says its
  noise floor is calibrated.
"""
import math
import os
import subprocess
import tempfile
import threading
import time
import unittest

import numpy as np
import rospkg
import rospy
import rostest

from diagnostic_msgs.msg import DiagnosticArray

from hri_sync.dance_off.expressiveness import expressiveness
from hri_sync.data_process.capture import window_stats
from hri_sync.msg import ClientResult, Decision, Skeleton
from hri_sync.ros.bags import read_skeletons
from hri_sync.ros.node import init_checker
from hri_sync.tools.procs import stop_group
from hri_sync.wire.vocabulary import MIN_COVERAGE

CLIENTS = ('left', 'right')
MARGIN = 0.005       # s: device clock map error and rounding at the edges
RECORDER_GRACE = 2.0  # s the recorder may lag this checker (see setUpClass)
RECORD = ['/sync_time', '/sync_ack', '/capture_data', '/round_status',
          '/client_result', '/decision', '/dance_off/config',
          '/left/captured', '/right/captured', '/calibration/capture_data',
          '/calibration/client_result', '/calibration/decision']


def diag(result, key):
    for kv in result.diagnostics:
        if kv.key == key:
            return kv.value
    return None


class DanceOffRound(unittest.TestCase):
    """One round through sensors, protocol, DPMs and DM."""

    @classmethod
    def setUpClass(cls):
        init_checker('dance_off_check')
        cls.expect = rospy.get_param('~expect')
        cls.rate = rospy.get_param('~rate', 20.0)
        cls.dur = rospy.get_param('~dur')
        cls.min_value = rospy.get_param('~min_expressiveness', 1.0)
        cls.still = rospy.get_param('~still', '').split(',')
        cls.movers = rospy.get_param('~movers', '').split(',')
        cls.nan_joints = rospy.get_param('~nan_joints', 0.0)
        cls.drop = rospy.get_param('~drop', 0.0)
        cls.verify = rospy.get_param('~verify', False)
        cls.expect_reason = rospy.get_param('~expect_reason', '')
        cls.expect_noise_floor = rospy.get_param('~expect_noise_floor',
                                                 False)
        cls.expect_diagnostics = [
            e.strip() for e in rospy.get_param(
                '~expect_diagnostics', '').split(';') if e.strip()]
        cls.timeout = rospy.get_param('~timeout', 60.0)
        cls.calibration = rospy.get_param('~calibration', 0.0)
        cls.calibrated, cls.calibration_decisions = {}, []
        cls.statuses = {c: rospy.get_param('~expect_status_' + c, 'ok')
                        for c in CLIENTS}
        cls.lock = threading.Lock()
        cls.results, cls.captured, cls.decisions = {}, {}, []
        cls.sent = {c: [] for c in CLIENTS}
        cls.recorder = None
        if cls.verify:
            cls.bag = os.path.join(tempfile.mkdtemp(prefix='dance_off_'),
                                   'round.bag')
            # The CM waits for it (~recorder) before round 1.
            cls.recorder = subprocess.Popen(
                ['rosbag', 'record', '-O', cls.bag] + RECORD
                + ['__name:=' + rospy.get_param('~recorder')],
                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                start_new_session=True)
        rospy.Subscriber('/client_result', ClientResult, cls.on_result)
        rospy.Subscriber('/decision', Decision, cls.on_decision)
        rospy.Subscriber('/calibration/client_result', ClientResult,
                         lambda m: cls.calibrated.__setitem__(m.client_id,
                                                              m))
        rospy.Subscriber('/calibration/decision', Decision,
                         cls.calibration_decisions.append)
        cls.expect_status = [
            e.strip().split('=', 1) for e in rospy.get_param(
                '~expect_status_text', '').split(';') if e.strip()]
        cls.statuses_seen = {}
        if cls.expect_status:
            rospy.Subscriber('/diagnostics', DiagnosticArray,
                             cls.on_diagnostics)
        for c in CLIENTS:
            rospy.Subscriber('/%s/captured' % c, Skeleton, cls.on_captured,
                             c, queue_size=10000)
            rospy.Subscriber('/%s/skeleton' % c, Skeleton,
                             lambda m, c=c: cls.sent[c].append(
                                 m.device_stamp.to_sec()),
                             queue_size=10000)
        deadline = time.time() + cls.timeout
        while not rospy.is_shutdown() and time.time() < deadline:
            with cls.lock:
                if cls.decisions:
                    break
            time.sleep(0.1)
        # Results and captured frames come on connections of their own: a
        # loaded checker may read them after the decision.  Wait for every
        # result and, in each window, the frames the result counts.
        deadline = time.time() + cls.timeout
        while not rospy.is_shutdown() and time.time() < deadline \
                and not cls.all_arrived():
            time.sleep(0.1)
        if cls.recorder is not None:
            # The recorder reads the same frames on connections of its
            # own, and what it has not read when it stops is not in the
            # bag: give it RECORDER_GRACE s.  Then Ctrl-C to its process
            # group (rosbag's wrapper and its record child), and wait for
            # the bag to be closed.
            time.sleep(RECORDER_GRACE)
            stop_group(cls.recorder, timeout=15)
            deadline = time.time() + 15
            while time.time() < deadline and (
                    os.path.exists(cls.bag + '.active')
                    or not os.path.exists(cls.bag)):
                time.sleep(0.1)

    @classmethod
    def all_arrived(cls):
        """True once every client's result and each result's captured
        frames arrived."""
        with cls.lock:
            if set(cls.results) < set(CLIENTS):
                return False
            for c, r in cls.results.items():
                window = [m for m in cls.captured.get(c, [])
                          if r.capture_start <= m.header.stamp
                          < r.capture_end]
                if len(window) < r.frames + r.frames_rejected:
                    return False
        return True

    @classmethod
    def on_result(cls, msg):
        with cls.lock:
            cls.results[msg.client_id] = msg

    @classmethod
    def on_captured(cls, msg, client):
        with cls.lock:
            cls.captured.setdefault(client, []).append(msg)

    @classmethod
    def on_diagnostics(cls, msg):
        with cls.lock:
            for s in msg.status:
                cls.statuses_seen.setdefault(s.name, set()).update(
                    [s.message] + [kv.value for kv in s.values])

    @classmethod
    def on_decision(cls, msg):
        with cls.lock:
            cls.decisions.append(msg)

    def decision(self):
        self.assertTrue(self.decisions, 'no /decision within %.0f s'
                        % self.timeout)
        return self.decisions[0]

    def test_decision(self):
        d = self.decision()
        self.assertEqual(list(d.clients), list(CLIENTS))
        if self.expect in ('no_winner', 'aborted'):
            self.assertEqual((d.outcome, d.winner), (self.expect, 0),
                             d.reason)
        else:
            number = int(self.expect[-1])
            self.assertEqual((d.outcome, d.winner), ('winner', number),
                             d.reason)
        for c, score in zip(CLIENTS, d.scores):
            self.assertIn(c, self.results)
            if self.statuses[c] in ('ok', 'partial'):
                self.assertEqual(score, self.results[c].value)
            else:
                self.assertTrue(math.isnan(score), (c, score))
                self.assertIn('%s has no usable result (%s)'
                              % (c, self.statuses[c]), d.reason)
        if any(s == 'partial' for s in self.statuses.values()):
            self.assertIn('partial', d.reason)
        if self.expect_reason:
            self.assertIn(self.expect_reason, d.reason)

    def test_bag_start(self):
        """With ~bag_start: each client scored its bag's first DUR s."""
        starts = [e.split('=', 1) for e in
                  rospy.get_param('~bag_start', '').split(';') if e]
        if not starts:
            self.skipTest('no ~bag_start')
        for client, path in starts:
            self.assertIn(client, self.results)
            frames, rel, _ = read_skeletons(path, '')
            first = [k for k, t in enumerate(rel) if t < self.dur]
            want = expressiveness(
                np.asarray(rel)[first],
                [[(p.x, p.y, p.z) for p in frames[k].positions]
                 for k in first],
                np.array([frames[k].confidence for k in first]),
                duration=self.dur).value
            got = self.results[client].value
            self.assertAlmostEqual(got, want, delta=0.03 * want,
                                   msg='%s scored %.4g, its bag\'s first '
                                   '%.1f s %.4g' % (client, got, self.dur,
                                                    want))

    def test_noise_floor(self):
        """With ~expect_noise_floor: every result reports a noise floor
        (finite, >= 0, below its score's scale) and the decision took it."""
        if not self.expect_noise_floor:
            return
        d = self.decision()
        self.assertEqual(len(d.noise_floors), len(CLIENTS))
        for c, floor in zip(CLIENTS, d.noise_floors):
            r = self.results[c]
            self.assertTrue(math.isfinite(r.noise_floor)
                            and r.noise_floor >= 0, (c, r.noise_floor))
            self.assertEqual(floor, r.noise_floor, c)
            rospy.loginfo('%s: score %.4g, noise floor %.4g', c, r.value,
                          r.noise_floor)

    def test_calibration(self):
        """With ~calibration: a no_winner answer to the calibration
        window, and the results' floors calibrated by it."""
        if not self.calibration:
            return
        self.decision()
        self.assertEqual(len(self.calibration_decisions), 1)
        cal = self.calibration_decisions[0]
        self.assertEqual((cal.round, cal.outcome, cal.winner),
                         (0, 'no_winner', 0), cal.reason)
        self.assertIn('calibration window', cal.reason)
        rospy.loginfo('calibration: %s', cal.reason)
        for c in CLIENTS:
            r, k = self.results.get(c), self.calibrated.get(c)
            if k is None or r is None or r.status not in ('ok', 'partial'):
                continue
            rospy.loginfo('%s: calibration %s, still score %.4g; round '
                          'score %.4g, noise floor %.4g (%s)', c, k.status,
                          k.value, r.value, r.noise_floor, r.noise_source)
            if k.status == 'ok':
                self.assertEqual(r.noise_source, 'calibration', c)
                self.assertGreaterEqual(r.noise_floor, k.value, c)

    def test_results(self):
        self.decision()
        period = 1.0 / self.rate
        for c in CLIENTS:
            r = self.results.get(c)
            self.assertIsNotNone(r, 'no result from %s' % c)
            # partial for ok: checked below against what the sensor sent
            starved = (r.status, self.statuses[c]) == ('partial', 'ok')
            if not starved:
                self.assertEqual(r.status, self.statuses[c], c)
            if r.status == 'no_data':
                self.assertEqual((r.frames, r.coverage), (0, 0.0), c)
                self.assertFalse(self.captured.get(c), c)
                continue
            self.assertTrue(math.isfinite(r.value), c)
            self.assertGreaterEqual(r.first_frame_offset, 0.0)
            window = [m for m in self.captured.get(c, [])
                      if r.capture_start <= m.header.stamp < r.capture_end]
            self.assertEqual(len(window), r.frames + r.frames_rejected, c)
            # What the sensor sent (its device stamps are the true clock,
            # which the time server serves): the DPM kept every frame of
            # the window's interior and started with the first one after
            # the start.  A loaded sensor may skip ticks; that is no loss.
            # The interior: beyond the window's own error bound (the map's
            # residual and moves) plus MARGIN (the map's bias) from each
            # edge, where a frame may be stamped to either side.
            start, end = r.capture_start.to_sec(), r.capture_end.to_sec()
            edge = MARGIN + (r.timing_uncertainty
                             if math.isfinite(r.timing_uncertainty) else 0.0)
            sent = [t for t in self.sent[c] if start + edge <= t < end - edge]
            kept = {round(m.device_stamp.to_sec(), 6) for m in window}
            lost = [t for t in sent if round(t, 6) not in kept]
            # A window that timed out waiting for its last frames (the
            # sensor's process descheduled past the completion margin on
            # a busy machine) misses only its tail, which the DPM counts
            # as late after its result.
            newest = max(kept, default=-math.inf)
            tail_late = diag(r, 'completed_by') == 'timeout' and lost \
                and min(lost) > newest
            if tail_late:
                rospy.logwarn('%s: the window timed out before its last %d '
                              'frames', c, len(lost))
                lost = []
            self.assertEqual(lost, [], '%s: %d sent frames not captured '
                             '(%.1f ms from the edges: %s)' % (
                                 c, len(lost), edge * 1e3,
                                 ', '.join('%.4f' % t for t in lost)))
            # The first frame is the first sent after the start: within
            # half a period, as the device clock map's bias (the least
            # transport delay it saw, 5 ms under make test-load) moves
            # the mapped stamp, not the frame.
            first_sent = min((t for t in self.sent[c] if t >= start),
                             default=end)
            self.assertLessEqual(r.first_frame_offset,
                                 first_sent - start + 0.5 * period, c)
            if starved and tail_late:
                # Its tail came after the completion margin (above): the
                # DPM rightly completed the window without it.
                rospy.logwarn('%s: partial: the window timed out before '
                              'its tail', c)
            elif starved:
                # A loaded sensor that skipped ticks sent less than the
                # window needs: partial is then right (the frames it sent
                # were all kept, above), within a period at either edge.
                sent_cov = window_stats(
                    sorted(t for t in self.sent[c] if start <= t < end),
                    start, end, max_period=period)['coverage']
                self.assertLess(sent_cov, MIN_COVERAGE + 2 * period / self.dur,
                                '%s: partial, but the sensor sent %.3f of '
                                'the window' % (c, sent_cov))
                rospy.logwarn('%s: partial: the loaded sensor sent %.3f of '
                              'the window', c, sent_cov)
            rospy.loginfo('%s: first frame %.1f ms after the start, %d of '
                          '%d ticks kept', c, r.first_frame_offset * 1e3,
                          len(window), int(self.dur * self.rate))
            if r.status == 'ok':
                self.assertGreaterEqual(r.coverage, 0.9, c)
                # A device map that moved s earlier mid-window (a slow
                # start of the transport) stamped a stretch twice: the
                # window's device times are one stretch more per move,
                # each with a frame at both ends.
                shift = float(diag(r, 'device_map_shift') or 0.0)
                moves = int(diag(r, 'device_map_moves') or 0)
                self.assertLessEqual(
                    r.frames, (self.dur + shift) * self.rate + 1 + moves,
                    '%s: device_map_shift %.3f s in %d moves'
                    % (c, shift, moves))
            elif r.status == 'partial':
                self.assertLess(r.coverage, 0.9, c)
                self.assertGreater(r.coverage, 0.0, c)
            if c in self.still:
                self.assertLess(r.value, self.min_value, c)
            if c in self.movers:
                self.assertGreater(r.value, self.min_value, c)
            if self.nan_joints > 0:
                self.assertGreater(int(diag(r, 'nonfinite_joints')), 0, c)
            if self.drop > 0:
                self.assertGreater(r.frames_dropped, 0, c)
        for expect in self.expect_diagnostics:
            client, _, rule = expect.partition(':')
            op = '>' if '>' in rule else '='
            key, _, value = rule.partition(op)
            r = self.results[client]
            got = getattr(r, key) if hasattr(r, key) else diag(r, key)
            self.assertIsNotNone(got, '%s: no %s' % (client, key))
            if op == '>':
                self.assertGreater(float(got), float(value), expect)
            else:
                self.assertEqual(str(got), value, expect)

    def test_status_text(self):
        if not self.expect_status:
            self.skipTest('no ~expect_status_text')
        self.decision()
        for name, text in self.expect_status:
            end = time.time() + 10.0
            while time.time() < end:
                with self.lock:
                    seen = set(self.statuses_seen.get(name, ()))
                if any(text in v for v in seen):
                    break
                time.sleep(0.2)
            self.assertTrue(any(text in v for v in seen),
                            '%s: no %r in %s' % (name, text, sorted(seen)))

    def test_verify_decisions(self):
        if not self.verify:
            self.skipTest('~verify is off for this round')
        self.decision()
        self.assertTrue(os.path.exists(self.bag), 'rosbag record made no bag'
                        + (' (still .active)' if os.path.exists(
                            self.bag + '.active') else ''))
        tool = os.path.join(rospkg.RosPack().get_path('hri_sync'), 'nodes',
                            'verify_decisions')
        out = subprocess.run(['/usr/bin/python3', tool, self.bag],
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                             universal_newlines=True, timeout=60)
        self.assertEqual(out.returncode, 0, out.stdout)
        d = self.decisions[0]
        self.assertIn('recomputed %s (participant %d)' % (d.outcome, d.winner)
                      if d.winner else 'recomputed %s' % d.outcome,
                      out.stdout)
        self.assertIn('all 1 rounds agree', out.stdout)


if __name__ == '__main__':
    rostest.rosrun('hri_sync', 'dance_off_check', DanceOffRound)
