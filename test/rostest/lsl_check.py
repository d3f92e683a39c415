#!/usr/bin/python3
"""Checks LSL in (issue 21 items 1 and 7) against true time.

``lsl_source.py`` writes each sample's true time into it (first channel,
or a marker's first word); the client ``~client`` captures the stream
through ``lsl_inlet`` and its DPM, and republishes the window's samples on
NS/<client>/captured with their global stamps.  Global time is the time
server's, here the true clock.  For every round this checks that the
result came, that every captured sample's global stamp is within the
result's timing_uncertainty (plus ~margin) of its true time (but for
samples whose source was preempted between reading the truth and its
stamp) and inside the window, and that the result counts them.  With
``~fault`` (vanish or reset, in the middle of round ``~fault_round``):
that round's result is not ok and says why in ``lsl_stream`` (``lost:
...``, ``clock_reset: ...``), no sample stamped wrongly got in, and the
next round's result says the stream is still lost or broken.  With
``~recover_round``: that round starts once the inlet reported the stream
back (RECOVERED) and a sample followed, and must be ok.  With ``~burst``
(the source pushes in bursts, stamped when pushed, nothing lost): every
round must be ok with no dropped sample, and the inlet's /diagnostics
(``<client>/lsl_inlet: lsl``) must count the bursts, no real gap and
its mapping's fit.
"""
import math
import threading
import time
import unittest

import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray
from std_srvs.srv import Trigger

from hri_sync.msg import ClientResult, DpmState, LslSample
from hri_sync.ros.node import init_checker
from hri_sync.ros.timers import wait_for
from hri_sync.data_process.capture import GAP_PERIODS

KIND_OF_FAULT = {'vanish': 'lost', 'stall': 'lost', 'reset': 'clock_reset'}


MAX_READ = 2e-4    # s: a truth that took longer to read was preempted


def truth_of(msg):
    """(the true time the source wrote into a sample, how long reading it
    and the stamp took)."""
    if msg.markers:
        truth, _, read = msg.markers[0].split()
        return float(truth), float(read)
    return msg.channels[0], msg.channels[2]


def index_of(msg):
    """The source's running sample number."""
    if msg.markers:
        return int(msg.markers[0].split()[1])
    return int(msg.channels[1])


def source_stalled(data, rate):
    """Whether a partial window is the source's own doing: no sample
    number missing among ``data`` (nothing lost on the way) and a gap of
    over GAP_PERIODS periods (a window's coverage rule) in the source's
    true send times (a source starved of CPU sends late, in a burst,
    stamped when sent)."""
    if rate <= 0 or not data:
        return False
    numbers = sorted(index_of(m) for _, m in data)
    truths = sorted(truth_of(m)[0] for _, m in data)
    return (numbers == list(range(numbers[0], numbers[-1] + 1))
            and max((b - a for a, b in zip(truths, truths[1:])),
                    default=0.0) > GAP_PERIODS / rate)


class LslCheck(unittest.TestCase):

    def setUp(self):
        self.client = rospy.get_param('~client', 'eeg')
        self.rounds = int(rospy.get_param('~rounds', 2))
        self.margin = float(rospy.get_param('~margin', 0.0005))
        self.rate = float(rospy.get_param('~rate', 0.0))
        self.fault = rospy.get_param('~fault', '')
        self.fault_round = int(rospy.get_param('~fault_round', 1))
        self.lock = threading.Lock()
        self.captured = []      # (global stamp, LslSample)
        self.results = {}
        rospy.Subscriber('/%s/captured' % self.client, LslSample,
                         self.on_captured, queue_size=100000)
        rospy.Subscriber('/client_result', ClientResult, self.on_result,
                         queue_size=100)
        self.fed = False
        rospy.Subscriber('/%s/dpm_state' % self.client, DpmState,
                         self.on_state)
        self.recover_round = int(rospy.get_param('~recover_round', 0))
        self.recovered = self.back = False
        rospy.Subscriber('/%s/lsl' % self.client, LslSample, self.on_lsl,
                         queue_size=1000)
        self.burst = float(rospy.get_param('~burst', 0.0))
        self.inlet = {}     # the inlet's last lsl status: values, level
        rospy.Subscriber('/diagnostics', DiagnosticArray,
                         self.on_diagnostics, queue_size=100)

    def on_diagnostics(self, msg):
        for s in msg.status:
            if s.name == '%s/lsl_inlet: lsl' % self.client and s.values:
                with self.lock:
                    self.inlet = dict({kv.key: kv.value for kv in s.values},
                                      level=s.level, message=s.message)

    def on_captured(self, msg):
        with self.lock:
            self.captured.append((msg.header.stamp.to_sec(), msg))

    def on_result(self, msg):
        if msg.client_id == self.client:
            with self.lock:
                self.results[msg.round] = msg

    def on_lsl(self, msg):
        """Recovered: a sample after the inlet reported the stream back."""
        if msg.kind == LslSample.RECOVERED:
            self.back = True
        self.recovered |= self.back and msg.kind == LslSample.DATA

    def on_state(self, msg):
        self.fed |= msg.samples > 0

    def run_rounds(self):
        """Start each round (the server has rounds:=0) once the DPM has
        had a sample (a loaded machine can start the inlet late, and the
        CPM rightly NACKs a silent sensor), and wait for its result."""
        self.assertTrue(wait_for(lambda: self.fed, 120.0, 0.1),
                        'the DPM never had a sample of the LSL stream')
        start = rospy.ServiceProxy('/control_module/start_round', Trigger)
        start.wait_for_service(60.0)
        for n in range(1, self.rounds + 1):
            if n == self.recover_round:
                self.assertTrue(wait_for(lambda: self.recovered, 90.0, 0.1),
                                'the inlet never reported the stream back')
            reply = start()     # returns at the round's end
            rospy.loginfo('lsl_check: round %d: %s', n, reply.message)
            wait_for(lambda: n in self.results, 30.0, 0.1)
        time.sleep(3.0)     # the captured samples follow their results

    def check_round(self, r):
        start, end = r.capture_start.to_sec(), r.capture_end.to_sec()
        d = {kv.key: kv.value for kv in r.diagnostics}
        with self.lock:
            data = [(s, m) for s, m in self.captured
                    if start <= s < end and m.kind == LslSample.DATA]
        truths = [truth_of(m) for _, m in data]
        errors = [s - t for (s, _), (t, read) in zip(data, truths)
                  if read <= MAX_READ]
        worst = max((abs(e) for e in errors), default=math.nan)
        rospy.loginfo(
            'lsl_check: round %d %s: %d samples, value %g, coverage %.2f, '
            'timing_uncertainty %.3f ms, |global - true| max %.3f ms, '
            'median %.3f ms (%d preempted sources left out); %s', r.round,
            r.status, len(data), r.value,
            r.coverage, r.timing_uncertainty * 1e3, worst * 1e3,
            sorted(abs(e) for e in errors)[len(errors) // 2] * 1e3
            if errors else math.nan, len(data) - len(errors),
            d.get('lsl_stream', 'stream ok'))
        for e in errors:
            self.assertLessEqual(
                abs(e), r.timing_uncertainty + self.margin,
                'round %d: a sample %.3f ms from its true time, beyond the '
                'reported bound %.3f ms + margin' % (
                    r.round, e * 1e3, r.timing_uncertainty * 1e3))
        self.assertEqual(int(r.value), len(data),
                         'round %d: the result counts %g samples, %d were '
                         'captured' % (r.round, r.value, len(data)))
        return d, data

    def test_rounds(self):
        self.run_rounds()
        with self.lock:
            missing = [n for n in range(1, self.rounds + 1)
                       if n not in self.results]
        self.assertFalse(missing, 'no result of rounds %s' % missing)
        for n in range(1, self.rounds + 1):
            r = self.results[n]
            d, data = self.check_round(r)
            if self.burst:
                self.assertEqual((r.status, r.frames_dropped),
                                 (ClientResult.OK, 0), d)
            if not self.fault or n < self.fault_round or \
                    n == self.recover_round:
                if r.status == ClientResult.PARTIAL and not self.burst \
                        and source_stalled(data, self.rate):
                    rospy.logwarn('lsl_check: round %d partial: the source '
                                  'was starved (a gap in its send times, '
                                  'no sample lost)', n)
                else:
                    self.assertEqual(r.status, ClientResult.OK, d)
                self.assertNotIn('lsl_stream', d)
                self.assertGreater(len(data), 0)
                continue
            kind = KIND_OF_FAULT[self.fault]
            self.assertNotEqual(r.status, ClientResult.OK, d)
            self.assertTrue(d.get('lsl_stream', '').startswith(kind),
                            'round %d: lsl_stream %r, not %s' % (
                                n, d.get('lsl_stream'), kind))
            if n == self.fault_round:
                self.assertGreater(len(data), 0, 'the samples before the '
                                   'fault are lost too')
            else:
                self.assertEqual(r.status, ClientResult.NO_DATA, d)


    def test_inlet_diagnostics(self):
        """The inlet's lsl status: samples, bursts, real gaps (none with
        ~burst) and the mapping's fit."""
        self.assertTrue(wait_for(lambda: self.inlet.get(
            'fit_estimates', '0') != '0', 60.0, 0.1),
            'no lsl status with a fit from the inlet: %s' % self.inlet)
        time.sleep(3.0)       # a few bursts, the next status
        with self.lock:
            v = dict(self.inlet)
        rospy.loginfo('lsl_check: the inlet on /diagnostics: %s', v)
        self.assertGreater(int(v['samples_received']), 0)
        self.assertGreater(float(v['fit_bound_ms']), 0.0)
        if self.burst:
            self.assertGreater(int(v['bursts']), 0, v)
            self.assertEqual((v['real_gaps'], v['level']), ('0', 0), v)


if __name__ == '__main__':
    init_checker('lsl_check')
    rostest.rosrun('hri_sync', 'lsl_check', LslCheck)
