"""Actions on ROS: round events to actions begun, each judged on time.

The executable is ``nodes/action_client``.
"""
import math
import threading
import time

import rospy

from hri_sync.msg import ActionEnd, ActionStart, Decision
from hri_sync.robot.actions import (TOLERANCE, ActionScheduler,
                                    ActionTally, ConfigError, await_end,
                                    parse_actions, run_firing)
from hri_sync.ros.action_kinds import executor
from hri_sync.client_process.ros_cpm import ClientProcess
from hri_sync.ros.inbox import Inbox
from hri_sync.ros.names import protocol_topic
from hri_sync.ros.outbox import Publisher
from hri_sync.ros.params import ParamError, param
from hri_sync.ros.stamps import header, stamp
from hri_sync.ros.timers import start_timing
from hri_sync.clock.truth import realtime, true_time, wait_until
from hri_sync.wire.validate import Context
from hri_sync.wire.vocabulary import Action

LOG = {'info': rospy.loginfo, 'warn': rospy.logwarn, 'error': rospy.logerr}


def log(level, text):
    LOG[level](text)


def log_outcome(text, ok, reason):
    """A start's or an end's line: info when ok (with its note), else
    an error with the reason."""
    if ok:
        rospy.loginfo(text + ('; ' + reason if reason else ''))
    else:
        rospy.logerr(text + ': ' + reason)


class ActionClient:
    """Feeds the scheduler the round's events and runs its firings."""

    def __init__(self):
        self.client_id = param('client_id', 'actions', str, bool)
        tolerance = param('tolerance', TOLERANCE, float,
                          lambda x: math.isfinite(x) and x >= 0, '>= 0 s')
        try:
            specs = parse_actions(param('actions', None, None, None,
                                        'a list of actions'), tolerance)
        except ConfigError as e:
            raise ParamError('~actions: %s' % e)
        self.start_spin, self.rt_priority = start_timing(
            self.client_id, 'actions may start late')
        try:
            self.executors = {s.name: executor(
                s, lambda: self.cpm.clock.now(), log) for s in specs}
        except ValueError as e:
            raise ParamError('~actions: %s' % e)
        self.scheduler = ActionScheduler(specs, log)
        self.lock = threading.Lock()
        self.start_pub = Publisher('~action_start', ActionStart,
                                   queue_size=100)
        self.end_pub = Publisher('~action_end', ActionEnd, queue_size=100)
        inbox = Inbox()
        self.tally = ActionTally()
        self.cpm = ClientProcess(self.client_id, self.on_capture,
                                 self.on_late, inbox)
        self.cpm.diagnostics.add('actions', self.tally.health)
        inbox.subscribe(protocol_topic('decision'), Decision,
                        self.on_decision, 'dm', context=self.context,
                        queue_size=10)
        self.cpm.start()
        rospy.loginfo('%s: ready; %d actions: %s', self.client_id,
                      len(specs), ', '.join('%s (%s at %s%+g s)' % (
                          s.name, s.kind, s.event, s.offset)
                          for s in specs))

    def context(self):
        """The global now, once the clock is usable."""
        clock = self.cpm.clock
        return Context(now=clock.now() if clock.ready else None)

    def on_capture(self, order):
        with self.lock:
            firings = self.scheduler.on_capture(order.round, order.start,
                                                order.end)
        self.spawn(firings)

    def on_late(self, late):
        with self.lock:
            firings = self.scheduler.on_late(late.round, late.start,
                                             late.end, late.reason)
        self.spawn(firings)

    def on_decision(self, msg):
        with self.lock:
            firings = self.scheduler.on_decision(
                msg.round, msg.outcome, msg.winner, msg.header.stamp.to_sec(),
                self.cpm.clock.now())
        self.spawn(firings)

    def spawn(self, firings):
        for f in firings:
            threading.Thread(target=self.run, args=(f,), daemon=True).start()

    def run(self, firing):
        now = self.cpm.clock.now
        with realtime(self.rt_priority):
            report = run_firing(
                firing, now,
                lambda t: wait_until(now, t, spin=self.start_spin,
                                     stop=rospy.is_shutdown),
                self.executors[firing.action.name],
                lambda: (time.time(), true_time()))
        if report is not None:
            self.report(report)
            end = await_end(report, now)
            if end is not None:
                self.report_end(end)

    def report(self, r):
        f, a = r.firing, r.firing.action
        self.tally.record(r)
        self.start_pub.publish(ActionStart(
            header=header(r.actual), round=f.round, client_id=self.client_id,
            action=a.name, scheduled=stamp(f.scheduled), offset=r.offset,
            true_time=stamp(r.true), kind=a.kind, event=a.event,
            status=r.status, reason=r.reason, tolerance=a.tolerance,
            local_time=stamp(r.local)))
        text = '%s: round %d: %s (%s, %s) %s at %+.2f ms from its scheduled ' \
            'time' % (self.client_id, f.round, a.name, a.kind, a.event,
                      r.status, r.offset * 1e3)
        log_outcome(text, r.status == Action.OK, r.reason)

    def report_end(self, r):
        f, a = r.firing, r.firing.action
        self.tally.record_end(r)
        self.end_pub.publish(ActionEnd(
            header=header(r.ended), round=f.round, client_id=self.client_id,
            action=a.name, kind=a.kind, event=a.event, status=r.status,
            reason=r.reason, started=stamp(r.start.actual),
            duration=r.duration, timeout=a.timeout))
        text = '%s: round %d: %s (%s, %s) ended %s after %.3f s' % (
            self.client_id, f.round, a.name, a.kind, a.event, r.status,
            r.duration)
        log_outcome(text, r.status == ActionEnd.OK, r.reason)
