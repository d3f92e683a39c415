"""hri_sync's round events out as LSL markers.

The executable is ``nodes/lsl_outlet``.
"""
import math
import socket
import time
import threading

import pylsl
import rospy

from hri_sync.msg import (ActionEnd, ActionStart, CaptureData,
                          ClientResult, Decision, RoundStatus, SyncTime)
from hri_sync.ros.diagnostics import NodeDiagnostics, clock_check
from hri_sync.ros.inbox import Inbox
from hri_sync.ros.names import protocol_topic
from hri_sync.ros.params import param
from hri_sync.clock.ros_synced_clock import SyncedClock
from hri_sync.wire.health import OK, WARN, Health
from hri_sync.wire.validate import Context
from hri_sync.tools import lsl_io
from hri_sync.tools.lsl_markers import (MarkerClock, Unread,
                                        capture_events, finite_or_none,
                                        marker_text)


class LslOutlet:
    """Reads ~params, keeps a clock, turns round events into markers."""

    def __init__(self):
        name = param('stream_name', 'hri_sync_events', str, bool, 'a name')
        source_id = param('source_id', 'hri_sync_events@%s'
                          % socket.gethostname(), str)
        self.outlet = pylsl.StreamOutlet(pylsl.StreamInfo(
            name, 'Markers', 1, pylsl.IRREGULAR_RATE, pylsl.cf_string,
            source_id))
        self.lock = threading.Lock()
        self.clock = MarkerClock()
        self.synced = SyncedClock(rospy.get_name().strip('/') or 'lsl_out')
        self.clock.model = self.synced.clock
        self.unread = Unread()
        self.counts = {'pushed': 0, 'no_clock': 0, 'invalid': 0}
        self.consumers = False
        diagnostics = NodeDiagnostics('server')
        diagnostics.add('clock', clock_check(self.synced))
        diagnostics.add('lsl', self.health)
        # Only the protocol's owners: the CM's sync, orders and aborts,
        # X's DPM (or CPM) for X's result, the DM's decision, X's own
        # ActionStart and ActionEnd; each validated (hri_sync.ros.inbox).
        self.inbox = Inbox()
        diagnostics.rejections(self.inbox.summary)
        for topic, kind, cb, role, client in (
                ('sync_time', SyncTime, self.on_sync, 'cm', None),
                ('capture_data', CaptureData, self.on_capture, 'cm', None),
                ('client_result', ClientResult, self.on_result, 'result',
                 lambda m: m.client_id),
                ('decision', Decision, self.on_decision, 'dm', None),
                ('round_status', RoundStatus, self.on_status, 'cm', None)):
            self.inbox.subscribe(protocol_topic(topic), kind, cb, role,
                                 client=client, context=self.context,
                                 queue_size=100)
        for key, default, kind, cb in (
                ('action_topics', ['dj_rob/action_start',
                                   'music/action_start',
                                   'actions/action_start'],
                 ActionStart, self.on_action),
                ('action_end_topics', ['actions/action_end'], ActionEnd,
                 self.on_action_end)):
            for topic in param(key, default, list):
                self.inbox.subscribe(protocol_topic(topic), kind, cb, 'cpm',
                                     client=lambda m: m.client_id,
                                     context=self.context, queue_size=10)
        rospy.loginfo('lsl_outlet: LSL marker stream %r (source_id %r)',
                      name, source_id)

    def context(self):
        """What an incoming message is judged against: this node's
        global now (unknown before its clock is usable)."""
        local = time.time()
        clock = self.synced.clock
        return Context(now=clock.to_global(local) if clock.ready else None,
                       local_now=local)

    def push(self, event, round_id, global_time, **fields):
        if not (math.isfinite(global_time) and global_time > 0):
            with self.lock:
                self.counts['invalid'] += 1
            rospy.logwarn_throttle(5, 'lsl_outlet: %s of round %d refused: '
                                   'its time %r is not a time', event,
                                   round_id, global_time)
            return
        with self.lock:
            try:
                stamp, bound = self.clock.to_lsl(
                    global_time, lsl_io.wall_minus_lsl())
            except ValueError as e:
                self.counts['no_clock'] += 1
                rospy.logwarn_throttle(5, 'lsl_outlet: %s of round %d not '
                                       'pushed: %s', event, round_id, e)
                return
            consumers = self.outlet.have_consumers()
            self.outlet.push_sample([marker_text(
                event, round_id, global_time, bound, **fields)], stamp)
            self.counts['pushed'] += 1
            if consumers != self.consumers:
                self.consumers = consumers
                rospy.loginfo('lsl_outlet: %s', 'an LSL consumer is '
                              'connected' if consumers else
                              'no LSL consumer is connected any more')
            note = self.unread.pushed(round_id, consumers)
        if note:
            rospy.logwarn('lsl_outlet: %s', note)

    def health(self):
        with self.lock:
            unread = self.unread.summary()
            values = (('markers_pushed', str(self.counts['pushed'])),
                      ('markers_unread', str(self.unread.total)),
                      ('unread_by_round', unread or 'none'),
                      ('not_pushed_no_clock', str(self.counts['no_clock'])),
                      ('refused_invalid_time', str(self.counts['invalid'])),
                      ('consumers', 'yes' if self.consumers else 'no'))
        if self.unread.total:
            return Health(WARN, '%d markers pushed with no LSL consumer '
                          'connected (rounds %s)' % (self.unread.total,
                                                     unread), values)
        return Health(OK, 'markers pushed: %d' % self.counts['pushed'],
                      values)

    def on_sync(self, msg):
        self.push('sync', msg.round, msg.header.stamp.to_sec())

    def on_capture(self, msg):
        for event, t, fields in capture_events(
                msg.round, msg.header.stamp.to_sec(), msg.str_aft, msg.dur,
                msg.clients):
            self.push(event, msg.round, t, **fields)

    def on_result(self, msg):
        self.push('result', msg.round, msg.header.stamp.to_sec(),
                  client=msg.client_id, status=msg.status,
                  value=finite_or_none(msg.value), frames=msg.frames,
                  coverage=finite_or_none(msg.coverage),
                  timing_uncertainty=finite_or_none(msg.timing_uncertainty))

    def on_decision(self, msg):
        self.push('decision', msg.round, msg.header.stamp.to_sec(),
                  outcome=msg.outcome, winner=msg.winner,
                  clients=list(msg.clients),
                  scores=[finite_or_none(s) for s in msg.scores],
                  reason=msg.reason)

    def on_status(self, msg):
        if msg.state == RoundStatus.ABORTED:
            self.push('round_aborted', msg.round, msg.header.stamp.to_sec(),
                      reason=msg.reason)

    def on_action(self, msg):
        self.push('action_start', msg.round, msg.header.stamp.to_sec(),
                  client=msg.client_id, action=msg.action,
                  scheduled=msg.scheduled.to_sec(), offset=msg.offset)

    def on_action_end(self, msg):
        self.push('action_end', msg.round, msg.header.stamp.to_sec(),
                  client=msg.client_id, action=msg.action, kind=msg.kind,
                  status=msg.status, reason=msg.reason,
                  started=msg.started.to_sec(),
                  duration=finite_or_none(msg.duration))
