"""The control module (CM) on ROS: rounds on the wire, its services.

The executable is ``nodes/control_module``.
"""
import dataclasses
import math
import threading
import time

import rosgraph
import rospy
from std_srvs.srv import Trigger, TriggerResponse

from hri_sync.msg import (CaptureData, ClockState, Decision, DpmState,
                          RoundStatus, SyncAck, SyncTime)
from hri_sync.control.calibration import CalibrationRun
from hri_sync.control.session import (ClientsWait, ControlSession, Log,
                                      Refused, RoundEnd, StatusUpdate,
                                      SyncOrder)
from hri_sync.control.health import ServerTally
from hri_sync.wire.protocol import Capture, ProtocolError, StrAftPolicy
from hri_sync.ros.inbox import Inbox
from hri_sync.ros.master_watch import keep_param, master_call
from hri_sync.ros.names import client_topic
from hri_sync.ros.outbox import Publisher
from hri_sync.ros.params import ParamError, csv_list, param, positive
from hri_sync.ros.stamps import header
from hri_sync.ros.timers import wait_for
from hri_sync.ros.recorder_link import RecorderLink
from hri_sync.clock.ros_clock_state import model_from_msg
from hri_sync.ros.diagnostics import round_diagnostics
from hri_sync.clock.ros_synced_clock import SyncedClock
from hri_sync.wire.validate import Context, Limits
from hri_sync.wire.vocabulary import CALIBRATION_NS

LOG = {'debug': rospy.logdebug, 'info': rospy.loginfo,
       'warn': rospy.logwarn, 'error': rospy.logerr}
POLL = 0.005  # s between two polls of a running round


class ControlModule:
    """The ROS shell around hri_sync.control.session.ControlSession."""

    def __init__(self):
        self.clients = param('clients', None, csv_list, bool,
                             'a comma-separated list of client ids')
        self.rounds = param('rounds', 1, int, lambda n: n >= 0, '>= 0')
        self.round_pause = param('round_pause', 1.0, float, lambda x: x >= 0,
                                 '>= 0 s')
        self.start_delay = param('start_delay', 1.0, float, lambda x: x >= 0,
                                 '>= 0 s')
        self.connect_timeout = param('connect_timeout', 60.0, float,
                                     positive, '> 0 s')
        self.connect_failures = param('connect_failures', 2, int,
                                      lambda n: n >= 1, '>= 1')
        # s to wait for the CPMs' links to sync_time and sync_ack once
        # nothing else is waited for; a CPM reached through a relay or
        # bridge never shows as linked.
        self.link_timeout = param('link_timeout', 10.0, float,
                                  lambda x: x >= 0, '>= 0 s')
        # s to wait for a sample from each participant's sensor (its DPM
        # heartbeat's count) once nothing else is waited for.
        self.sample_timeout = param('sample_timeout', 10.0, float,
                                    lambda x: x >= 0, '>= 0 s')
        # A recorder node (rosbag record) to wait for before round 1:
        # connected to every publisher of what it records (~link_timeout).
        recorder = param('recorder', '', str)
        self.recorder = RecorderLink(
            rospy.resolve_name(recorder),
            master_call(rospy.get_name(), rosgraph.get_master_uri()),
            rospy.get_name()) if recorder else None
        # Participants have a DPM, whose heartbeat their CPM needs to ACK.
        self.participants = param('participants', '', csv_list) or \
            self.clients
        ack_timeout = param('ack_timeout', 3.0, float, positive, '> 0 s')
        decision_timeout = param('decision_timeout', 5.0, float, positive,
                                 '> 0 s')
        # s of the calibration window before round 1 (0: none)
        calibration = param('calibration', 5.0, float, lambda x: x >= 0,
                            '>= 0 s (0: none)')
        try:
            self.calibration = CalibrationRun(
                self.participants, calibration,
                param('calibration_lead', 1.0, float), decision_timeout) \
                if calibration else None
            self.session = ControlSession(
                self.clients, param('dur', 10.0, float, positive, '> 0 s'),
                StrAftPolicy.parse(
                    param('str_aft', 'auto'),
                    param('str_aft_margin', 0.25, float, positive, '> 0 s')),
                param('min_clients', 0, int, lambda n: n >= 0,
                      '0 (every client) or a quorum') or None,
                ack_timeout, decision_timeout,
                param('first_round', 1, int, lambda n: n >= 1, '>= 1'))
        except ProtocolError as e:
            raise ParamError(str(e))
        self.synced_clock = SyncedClock('server')
        self.tally = ServerTally(self.clients)
        self.lock = threading.Lock()   # the session, between threads
        # No round ahead of the CM's own; an ACK's dispatch latency
        # (which STR_AFT auto follows) is at most the ACK timeout.
        self.limits = Limits(rounds_ahead=0, max_latency=ack_timeout)
        # The protocol topics, in the system namespace (this node's).
        self.sync_pub = Publisher('sync_time', SyncTime, queue_size=10)
        self.capture_pub = Publisher('capture_data', CaptureData,
                                     queue_size=10, latch=True)
        self.status_pub = Publisher('round_status', RoundStatus,
                                    queue_size=10, latch=True)
        self.inbox = Inbox()
        self.ack_sub = self.inbox.subscribe(
            'sync_ack', SyncAck, self.on_ack, 'cpm',
            client=lambda m: m.client_id, context=self.context,
            queue_size=50)
        decision_topic = rospy.resolve_name('decision')
        self.inbox.subscribe(decision_topic, Decision, self.on_decision,
                             'dm', context=self.context)
        self.calibration_pub = self.calibration_links()
        round_diagnostics('server', self.tally, self.synced_clock).rejections(
            self.inbox.summary, lambda: {
                decision_topic + ' ' + why: n for why, n in
                dict(self.session.ignored).items() if why != 'old_round'})
        self.clients_waited = threading.Event()
        rospy.Service('~start_round', Trigger, self.on_start_round)

    def call(self, event, *args):
        """Feed the session an event; put its outputs out; return them."""
        with self.lock:
            outputs = event(*args)
        for out in outputs:
            if isinstance(out, Log):
                LOG[out.level](out.text)
            elif isinstance(out, SyncOrder):
                self.sync_pub.publish(SyncTime(header=header(out.stamp),
                                               round=out.round))
            elif isinstance(out, RoundEnd):
                self.tally.on_end(out.round, out.outcome, out.message)
            elif isinstance(out, StatusUpdate):
                self.tally.on_status(out.round, out.state, out.reason,
                                     out.refused, out.missing)
                self.status_pub.publish(RoundStatus(
                    # NaN: the server has no clock, so no time.
                    header=header(None if math.isnan(out.stamp)
                                  else out.stamp),
                    round=out.round, state=out.state, reason=out.reason,
                    acked=out.acked, refused=out.refused,
                    missing=out.missing))
            elif isinstance(out, Capture):
                self.capture_pub.publish(CaptureData(
                    header=header(out.cr_t), round=out.round,
                    str_aft=out.str_aft, dur=out.dur, clients=out.clients))
        return outputs

    def context(self):
        """What an incoming message is judged against: the server's
        global now, the round in progress and its sync_time stamp."""
        clock = self.synced_clock.clock
        sent = self.session.sync_stamp
        return Context(now=clock.now() if clock.ready else None,
                       round=self.session.round, limits=self.limits,
                       sync_sent=sent if math.isfinite(sent) else None)

    def on_ack(self, msg):
        self.call(self.session.on_ack, msg)

    def on_decision(self, msg):
        self.call(self.session.on_decision, msg.round)

    def on_start_round(self, _req):
        # The first call waits, as round 1 of a fixed count does, until
        # the clients are ready (wait_for_clients, bounded by it).
        self.clients_waited.wait()
        end = self.run_round()
        return TriggerResponse(end.ok, end.message)

    def run_round(self):
        """Start a round and drive it to its end: its RoundEnd, or Refused
        while another round runs."""
        clock = self.synced_clock.clock
        outputs = self.call(self.session.start, clock.now(), clock.ready,
                            self.synced_clock.last_error)
        for out in outputs:
            if isinstance(out, Refused):
                return out
            if isinstance(out, StatusUpdate):
                round_id = out.round
        keep_param('first_round', round_id + 1)
        while self.session.result(round_id) is None:
            if rospy.is_shutdown():
                self.call(self.session.shutdown)
            else:
                time.sleep(POLL)
                self.call(self.session.poll, clock.now())
        return self.session.result(round_id)

    def linked_clients(self):
        """The clients one of whose CPM nodes is connected to this node's
        sync_time publisher and sync_ack subscriber now."""
        out_ids = {t.endpoint_id for t in self.sync_pub.impl.connections}
        in_ids = {getattr(t, 'header', None) and t.header.get('callerid')
                  for t in self.ack_sub.impl.connections}
        return {c for c in self.clients
                if self.inbox.senders.names('cpm', c) & out_ids & in_ids}

    def wait_for_clients(self):
        """Wait until every client's clock is usable, its CPM linked and
        every participant's DPM heard with a sample from its sensor, or a
        client's sync failed
        ~connect_failures times in a row (it will NACK with the reason),
        for at most ~connect_timeout; say every 5 s whom it waits for."""
        wait = ClientsWait(self.clients, self.connect_failures,
                           self.participants, self.link_timeout,
                           self.sample_timeout)
        lock = threading.Lock()

        def on_dpm(msg, client):
            with lock:
                wait.on_dpm(client, msg.samples, msg.refused_reason)

        def on_state(msg, client):
            try:
                model_from_msg(msg)
                usable, reason = True, ''
            except ValueError as e:
                usable, reason = False, str(e)
            with lock:
                wait.on_state(client, usable, reason)

        subs = [rospy.Subscriber(client_topic(c, 'clock_state'),
                                 ClockState, on_state, c)
                for c in self.clients]
        subs += [self.inbox.subscribe(
            client_topic(c, 'dpm_state'), DpmState,
            lambda m, c=c: on_dpm(m, c), 'dpm', client=c,
            context=lambda: Context(local_now=time.time()), queue_size=1)
            for c in wait.dpms]
        start = time.monotonic()
        while not rospy.is_shutdown():
            now = time.monotonic()
            waited = now - start
            linked = self.linked_clients()
            with lock:
                unlinked = wait.on_links(linked, now)
                unfed = wait.on_samples(now)
                waiting = wait.waiting()
                text = wait.describe(waiting)
            if unlinked:
                rospy.logwarn('not waiting any longer (~link_timeout %.0f s) '
                              'for the CPMs of %s to connect to sync_time and '
                              'sync_ack (reached through a relay or bridge?)',
                              self.link_timeout, ', '.join(unlinked))
            if unfed:
                rospy.logwarn('not waiting any longer (~sample_timeout %.0f '
                              's) for a sample from the sensors of %s: their '
                              'CPMs will NACK naming them',
                              self.sample_timeout, ', '.join(unfed))
            if not waiting or waited >= self.connect_timeout:
                break
            rospy.loginfo_throttle(5, 'waiting %.0f of %.0f s '
                                   '(~connect_timeout) for %s'
                                   % (waited, self.connect_timeout, text))
            time.sleep(0.05)
        for sub in subs:
            sub.unregister()
        with lock:
            unsynced = wait.unsynced()
            unready = [c for c in wait.unready() if c not in unsynced]
            text = wait.describe(unsynced + unready)
        if unsynced or unready:
            rospy.logwarn('starting without a usable clock, a linked CPM, '
                          'a DPM heartbeat or a sensor sample from %s after '
                          '%.1f s (~connect_timeout %.0f s): they will NACK '
                          'or be missing', text,
                          time.monotonic() - start, self.connect_timeout)

    def wait_for_dm(self):
        """Wait, at most ~link_timeout s, until a decision module is
        connected to capture_data: one that hears an order late ignores
        the results that came before it, and the round has no decision."""
        dms = self.inbox.senders.names('dm')
        if not wait_for(lambda: dms & {
                t.endpoint_id for t in self.capture_pub.impl.connections},
                self.link_timeout):
            rospy.logwarn('no decision module (%s) connected to capture_data '
                          'after ~link_timeout %.0f s: starting without it',
                          ', '.join(sorted(dms)), self.link_timeout)

    def calibration_links(self):
        """The calibration's order publisher; the decision module's
        answer subscribed."""
        self.inbox.subscribe(
            CALIBRATION_NS + '/decision', Decision,
            lambda m: self.calibrate_event('on_decision', m.round), 'dm',
            context=lambda: dataclasses.replace(self.context(), round=None,
                                                calibration=True))
        return Publisher(CALIBRATION_NS + '/capture_data', CaptureData,
                         queue_size=10)

    def calibrate_event(self, event, *args):
        """Feed the calibration an event; log its lines, send its order."""
        with self.lock:
            outputs = getattr(self.calibration, event)(*args) \
                if self.calibration else []
        for out in outputs:
            if isinstance(out, Log):
                LOG[out.level](out.text)
            elif isinstance(out, Capture):
                self.calibration_pub.publish(CaptureData(
                    header=header(out.cr_t), round=out.round,
                    str_aft=out.str_aft, dur=out.dur, clients=out.clients))

    def calibrate(self):
        """The calibration window (~calibration s, nobody moving) before
        the first round: ordered once the decision module and the
        participants' DPMs are connected to calibration/capture_data (at
        most ~link_timeout s), over when the decision module answered or
        its deadline passed.  None on a respawn (after round 1) or
        without this node's clock."""
        clock = self.synced_clock.clock
        if self.calibration is None or self.session.round != 0:
            return
        if not clock.ready:
            rospy.logerr('calibration skipped: the server\'s clock is not '
                         'synced (%s)', self.synced_clock.last_error)
            return
        wanted = [self.inbox.senders.names('dm')] + [
            self.inbox.senders.names('dpm', c) for c in self.participants]
        if not wait_for(lambda: all(names & {
                t.endpoint_id for t in self.calibration_pub.impl.connections}
                for names in wanted), self.link_timeout):
            rospy.logwarn('calibration: not every participant\'s DPM and '
                          'the decision module connected to its order '
                          'after ~link_timeout %.0f s', self.link_timeout)
        self.calibrate_event('start', clock.now())
        while not (self.calibration.done or rospy.is_shutdown()):
            time.sleep(POLL)
            self.calibrate_event('poll', clock.now())

    def wait_for_recorder(self):
        """Wait, at most ~link_timeout s, until ~recorder is connected to
        every publisher of the topics it records: what is sent before a
        connection is not in the bag."""
        if self.recorder is None:
            return
        missing = ['']

        def linked():
            missing[0] = self.recorder.missing()
            return not missing[0]
        if wait_for(linked, self.link_timeout, poll=0.2):
            rospy.loginfo('the recorder %s is connected to every publisher '
                          'of what it records', self.recorder.recorder)
        elif not rospy.is_shutdown():
            rospy.logwarn('recorder not ready after ~link_timeout %.0f s: '
                          '%s; starting: the bag lacks what is sent '
                          'before a connection', self.link_timeout,
                          missing[0])

    def run(self):
        if self.rounds == 0:
            # The calls wait for the clients (and the calibration, when
            # this node's clock is synced by then), not for the clock: a
            # round without it aborts at once and says so.
            rospy.loginfo('waiting for ~start_round calls (next: round %d)',
                          self.session.round + 1)
            self.wait_for_clients()
            self.wait_for_recorder()
            self.calibrate()
            self.clients_waited.set()
        if not self.synced_clock.wait_ready(self.connect_timeout):
            if rospy.is_shutdown():
                return
            rospy.logerr('server cannot sync to its time server: %s',
                         self.synced_clock.last_error)
        if self.rounds == 0:
            rospy.spin()
            self.call(self.session.shutdown)
            return
        self.wait_for_clients()
        self.wait_for_dm()
        self.wait_for_recorder()
        self.calibrate()
        self.clients_waited.set()
        rospy.sleep(self.start_delay)
        for n in range(self.rounds):
            if n:
                rospy.sleep(self.round_pause)
            end = self.run_round()
            while isinstance(end, Refused):   # a ~start_round call's round
                wait_for(lambda: self.session.idle, float('inf'))
                if rospy.is_shutdown():
                    return
                end = self.run_round()
            rospy.loginfo('round %d: %s', end.round, end.message)
        rospy.loginfo('all %d rounds done; control module exits', self.rounds)
        rospy.sleep(0.5)  # let the last messages go out
