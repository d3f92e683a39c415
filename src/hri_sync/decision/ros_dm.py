"""The decision module (DM) on ROS: results in, decisions out.

The executable is ``nodes/decision_module``.
"""
import math
import threading
import time

import rospy

from hri_sync.msg import (CaptureData, ClientResult, ClockState, Decision,
                          RoundStatus)
from hri_sync.clock.ros_clock_state import model_from_msg
from hri_sync.ros.diagnostics import DecisionDiagnostics
from hri_sync.ros.inbox import Inbox
from hri_sync.ros.outbox import Publisher
from hri_sync.ros.params import ParamError, csv_list, param, positive
from hri_sync.ros.stamps import header, stamp
from hri_sync.decision.rule import (ABORTED, DEFAULT_NOISE_FACTOR, ON_MISSING,
                                    RULES, RoundCollector)
from hri_sync.wire.protocol import Capture
from hri_sync.wire.validate import Context


class DecisionModule:
    """Reads ~params and wires topics to a RoundCollector."""

    def __init__(self):
        self.participants = param('participants', None, csv_list, bool,
                                  'the clients whose results are compared')
        try:
            self.collector = RoundCollector(
                self.participants,
                param('result_timeout', 2.0, float, positive, '> 0 s'),
                param('min_expressiveness', 0.0, float, math.isfinite,
                      'a finite number'),
                param('tie_margin', 0.0, float, lambda x: x >= 0, '>= 0'),
                param('on_missing', 'partial', str,
                      lambda m: m in ON_MISSING, ' or '.join(ON_MISSING)),
                rule=param('decision_rule', 'threshold', str,
                           lambda r: r in RULES, ' or '.join(RULES)),
                noise_factor=param('noise_factor', DEFAULT_NOISE_FACTOR,
                                   float, lambda x: math.isfinite(x)
                                   and x >= 0, '>= 0'))
        except ValueError as e:
            raise ParamError(str(e))
        self.lock = threading.Lock()
        self.pub = Publisher('decision', Decision, queue_size=10,
                             latch=True)
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
            self.participants, clock_topic,
            lambda: dict(self.collector.ignored, **{
                'noise floor unknown (%s)' % c: n for c, n in
                self.collector.noise_unknown.items()}), self.inbox.summary)
        self.inbox.subscribe(clock_topic, ClockState, self.on_clock, 'cm',
                             client='server', context=self.context)
        self.inbox.subscribe('capture_data', CaptureData, self.on_capture,
                             'cm', context=self.context)
        self.inbox.subscribe('round_status', RoundStatus, self.on_status,
                             'cm', context=self.context)
        self.inbox.subscribe('client_result', ClientResult, self.on_result,
                             'result', client=lambda m: m.client_id,
                             context=self.context, queue_size=50)
        threading.Thread(target=self.poll, daemon=True).start()

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

    def now(self):
        """Global now; the local clock while the server is not synced."""
        clock = self.clock
        if clock is None:
            rospy.logwarn_throttle(10, 'no synced /server/clock_state: '
                                   'deadlines on the local clock')
            return time.time()
        return clock.to_global(time.time())

    def on_capture(self, msg):
        end = Capture.from_msg(msg).end
        with self.lock:
            opened = self.collector.open(msg.round, end)
        if opened:
            rospy.loginfo('round %d: results due by global %.3f (%.3f s '
                          'from now)', msg.round,
                          end + self.collector.result_timeout,
                          end + self.collector.result_timeout - self.now())

    def on_status(self, msg):
        if msg.state == RoundStatus.ABORTED:
            with self.lock:
                closed = self.collector.abort(msg.round, msg.reason)
            if closed:
                self.publish(closed)

    def on_result(self, msg):
        with self.lock:
            unknown = self.collector.noise_unknown[msg.client_id]
            closed, why = self.collector.add(
                msg.round, msg.client_id, msg.status, msg.value,
                msg.timing_uncertainty, msg.noise_floor)
            ignored = dict(self.collector.ignored)
            if self.collector.noise_unknown[msg.client_id] > unknown \
                    and self.collector.rule[3] == 'noise':
                rospy.logwarn_throttle(
                    10, 'result of %s for round %d: noise floor %r unknown '
                    '(%d so far): the min_expressiveness rule for it',
                    msg.client_id, msg.round, msg.noise_floor,
                    self.collector.noise_unknown[msg.client_id])
        if why:
            rospy.logwarn('result of %s for round %d ignored (%s); ignored '
                          'so far: %s', msg.client_id, msg.round, why,
                          ignored)
        else:
            self.diagnostics.tally.on_result(msg.round, msg.client_id,
                                             msg.status)
        if closed:
            self.publish(closed)

    def poll(self):
        """Rounds past their deadline: checked every 5 ms from the first
        deadline on, every 0.1 s before."""
        while not rospy.is_shutdown():
            with self.lock:
                deadline = self.collector.next_deadline()
            if deadline is None:
                time.sleep(0.1)
                continue
            now = self.now()
            with self.lock:
                closed = self.collector.due(now)
            for c in closed:
                self.publish(c)
            time.sleep(min(0.1, max(0.005, deadline - now)))

    def publish(self, closed):
        v = closed.verdict
        self.diagnostics.tally.on_decision(closed.round, v.outcome, v.reason,
                                           closed.why != ABORTED)
        now = self.now()
        self.pub.publish(Decision(
            header=header(now if self.clock else None), round=closed.round,
            outcome=v.outcome, winner=v.winner, clients=self.participants,
            scores=v.scores, reason=v.reason,
            noise_floors=v.noise_floors or [],
            window_end=stamp(closed.window_end if math.isfinite(
                closed.window_end) else None),
            timing_uncertainty=closed.timing_uncertainty))
        rospy.loginfo(
            'round %d decision: %s%s (%s) scores %s; on %s, %.1f ms after '
            'the window end; timing uncertainty %.3f ms', closed.round,
            v.outcome, ' participant %d' % v.winner if v.winner else '',
            v.reason, ', '.join('%s=%.6g' % cs for cs in
                                zip(self.participants, v.scores)),
            closed.why, (now - closed.window_end) * 1e3,
            closed.timing_uncertainty * 1e3)
