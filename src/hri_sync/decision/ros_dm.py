"""The decision module (DM) on ROS: results in, decisions out.

The executable is ``nodes/decision_module``.
"""
import dataclasses
import math
import threading
import time

import rospy

from hri_sync.msg import (CaptureData, ClientResult, ClockState, Decision,
                          RoundStatus)
from hri_sync.clock.ros_clock_state import model_from_msg
from hri_sync.decision.health import noise_health
from hri_sync.ros.diagnostics import DecisionDiagnostics
from hri_sync.ros.inbox import Inbox
from hri_sync.ros.outbox import Publisher
from hri_sync.ros.params import ParamError, csv_list, param, positive
from hri_sync.ros.stamps import header, stamp
from hri_sync.decision.rule import (ABORTED, DEFAULT_NOISE_FACTOR, NOISE,
                                    ON_MISSING, RULES, RoundCollector)
from hri_sync.wire.protocol import Capture
from hri_sync.wire.validate import Context
from hri_sync.wire.vocabulary import CALIBRATION_NS


class DecisionModule:
    """Reads ~params and wires topics to a RoundCollector."""

    def __init__(self):
        self.participants = param('participants', None, csv_list, bool,
                                  'the clients whose results are compared')
        result_timeout = param('result_timeout', 2.0, float, positive,
                               '> 0 s')
        try:
            self.collector = RoundCollector(
                self.participants, result_timeout,
                param('min_expressiveness', 0.0, float, math.isfinite,
                      'a finite number'),
                param('tie_margin', 0.0, float, lambda x: x >= 0, '>= 0'),
                param('on_missing', 'partial', str,
                      lambda m: m in ON_MISSING, ' or '.join(ON_MISSING)),
                rule=param('decision_rule', NOISE, str,
                           lambda r: r in RULES, ' or '.join(RULES)),
                noise_factor=param('noise_factor', DEFAULT_NOISE_FACTOR,
                                   float, lambda x: math.isfinite(x)
                                   and x >= 0, '>= 0'))
        except ValueError as e:
            raise ParamError(str(e))
        self.lock = threading.Lock()
        # The calibration window: its results, answered with no winner.
        self.calibration = RoundCollector(self.participants, result_timeout,
                                          calibration=True)
        self.pub = Publisher('decision', Decision, queue_size=10,
                             latch=True)
        self.calibration_pub = Publisher(CALIBRATION_NS + '/decision',
                                         Decision, queue_size=10, latch=True)
        # The server host's global clock, kept by the CM (latched).
        self.clock = None
        # Only the CM opens, aborts and times rounds; only X's DPM (or its
        # CPM, for a late window) reports X's result; all validated.
        if rospy.has_param('~clock_state'):
            raise ParamError('~clock_state is gone: remap the topic, '
                             'server/clock_state:=%s'
                             % rospy.get_param('~clock_state'))
        clock_topic = rospy.resolve_name('server/clock_state')
        self.inbox = Inbox()
        self.diagnostics = DecisionDiagnostics(
            self.participants, clock_topic, self.noise_health,
            lambda: dict(self.collector.ignored), self.inbox.summary,
            self.calibration_rejections)
        self.inbox.subscribe(clock_topic, ClockState, self.on_clock, 'cm',
                             client='server', context=self.context)
        self.inbox.subscribe('capture_data', CaptureData, self.on_capture,
                             'cm', context=self.context)
        self.inbox.subscribe('round_status', RoundStatus, self.on_status,
                             'cm', context=self.context)
        self.inbox.subscribe('client_result', ClientResult, self.on_result,
                             'result', client=lambda m: m.client_id,
                             context=self.context, queue_size=50)
        self.inbox.subscribe(CALIBRATION_NS + '/capture_data', CaptureData,
                             self.on_calibration, 'cm',
                             context=self.calibration_context)
        self.inbox.subscribe(CALIBRATION_NS + '/client_result', ClientResult,
                             self.on_calibration_result, 'result',
                             client=lambda m: m.client_id,
                             context=self.calibration_context, queue_size=50)
        threading.Thread(target=self.poll, daemon=True).start()

    def noise_health(self):
        """The ``noise floors`` status of /diagnostics."""
        with self.lock:
            c = self.collector
            return noise_health(c.rule[3] == NOISE, self.participants,
                                dict(c.noise_sources), dict(c.noise_unknown),
                                dict(c.noise_uncalibrated))

    def calibration_rejections(self):
        """{'<calibration topic> <reason>': n}: the calibration's orders
        and results not taken."""
        return {'%s %s' % (rospy.resolve_name(CALIBRATION_NS + (
            '/capture_data' if why in DecisionDiagnostics.CAPTURE_REASONS
            else '/client_result')), why): n
            for why, n in dict(self.calibration.ignored).items()}

    def on_clock(self, msg):
        self.diagnostics.clock.on_state(msg)
        try:
            self.clock = model_from_msg(msg)
        except ValueError as e:     # keeps the last good model
            rospy.logwarn_throttle(10, 'decision module: %s', e)

    def context(self):
        """What an incoming message is judged against: the server's
        global now (unknown before its clock state) and the local now."""
        local = time.time()
        clock = self.clock
        return Context(now=clock.to_global(local) if clock else None,
                       local_now=local)

    def calibration_context(self):
        """The context of the calibration/ topics' messages (round 0)."""
        return dataclasses.replace(self.context(), calibration=True)

    def now(self):
        """Global now; the local clock while the server is not synced."""
        clock = self.clock
        if clock is None:
            rospy.logwarn_throttle(10, 'no synced /server/clock_state: '
                                   'deadlines on the local clock')
            return time.time()
        return clock.to_global(time.time())

    def on_capture(self, msg, collector=None):
        collector = collector or self.collector
        end = Capture.from_msg(msg).end
        with self.lock:
            opened = collector.open(msg.round, end)
        if opened:
            rospy.loginfo('%s: results due by global %.3f (%.3f s from '
                          'now)', self.name(collector, msg.round),
                          end + collector.result_timeout,
                          end + collector.result_timeout - self.now())

    def on_calibration(self, msg):
        self.on_capture(msg, self.calibration)

    def on_status(self, msg):
        if msg.state == RoundStatus.ABORTED:
            with self.lock:
                closed = self.collector.abort(msg.round, msg.reason)
            if closed:
                self.publish(closed)

    @staticmethod
    def name(collector, round_id):
        """'round N', or 'calibration' for the calibration's collector."""
        return 'calibration' if collector.calibration else \
            'round %d' % round_id

    def on_result(self, msg, collector=None):
        collector = collector or self.collector
        with self.lock:
            before = collector.noise_uncalibrated[msg.client_id]
            closed, why = collector.add(
                msg.round, msg.client_id, msg.status, msg.value,
                msg.timing_uncertainty, msg.noise_floor, msg.noise_source)
            ignored = dict(collector.ignored)
            if collector.noise_uncalibrated[msg.client_id] > before \
                    and collector.rule[3] == NOISE:
                rospy.logwarn_throttle(
                    10, 'result of %s for round %d: its noise floor %.4g '
                    'is not calibrated (%d so far): the min_expressiveness '
                    'rule for it', msg.client_id, msg.round,
                    msg.noise_floor,
                    collector.noise_uncalibrated[msg.client_id])
        if why:
            rospy.logwarn('result of %s for %s ignored (%s); ignored so '
                          'far: %s', msg.client_id,
                          self.name(collector, msg.round), why, ignored)
        elif not collector.calibration:
            self.diagnostics.tally.on_result(msg.round, msg.client_id,
                                             msg.status)
        if closed:
            self.publish(closed, collector)

    def on_calibration_result(self, msg):
        self.on_result(msg, self.calibration)

    def poll(self):
        """Rounds past their deadline: checked every 5 ms from the first
        deadline on, every 0.1 s before."""
        while not rospy.is_shutdown():
            with self.lock:
                deadline = min((d for d in (
                    self.collector.next_deadline(),
                    self.calibration.next_deadline()) if d is not None),
                    default=None)
            if deadline is None:
                time.sleep(0.1)
                continue
            now = self.now()
            with self.lock:
                closed = [(c, self.collector) for c in
                          self.collector.due(now)] + \
                    [(c, self.calibration) for c in
                     self.calibration.due(now)]
            for c, collector in closed:
                self.publish(c, collector)
            time.sleep(min(0.1, max(0.005, deadline - now)))

    def publish(self, closed, collector=None):
        collector = collector or self.collector
        v = closed.verdict
        if not collector.calibration:
            self.diagnostics.tally.on_decision(
                closed.round, v.outcome, v.reason, closed.why != ABORTED)
        now = self.now()
        pub = self.calibration_pub if collector.calibration else self.pub
        pub.publish(Decision(
            header=header(now if self.clock else None), round=closed.round,
            outcome=v.outcome, winner=v.winner, clients=self.participants,
            scores=v.scores, reason=v.reason,
            noise_floors=v.noise_floors or [],
            window_end=stamp(closed.window_end if math.isfinite(
                closed.window_end) else None),
            timing_uncertainty=closed.timing_uncertainty))
        rospy.loginfo(
            '%s decision: %s%s (%s) scores %s; on %s, %.1f ms after '
            'the window end; timing uncertainty %.3f ms',
            self.name(collector, closed.round),
            v.outcome, ' participant %d' % v.winner if v.winner else '',
            v.reason, ', '.join('%s=%.6g' % cs for cs in
                                zip(self.participants, v.scores)),
            closed.why, (now - closed.window_end) * 1e3,
            closed.timing_uncertainty * 1e3)
