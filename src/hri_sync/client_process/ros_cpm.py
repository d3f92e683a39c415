"""The client process module (CPM) on ROS: ACKs and capture orders."""
import math
import time
from collections import Counter

import rospy
from diagnostic_msgs.msg import DiagnosticStatus

from hri_sync.msg import CaptureData, DpmState, SyncAck, SyncTime
from hri_sync.ros.diagnostics import round_diagnostics
from hri_sync.ros.inbox import Inbox
from hri_sync.ros.names import client_topic, protocol_topic
from hri_sync.ros.outbox import Publisher
from hri_sync.ros.params import ParamError, param, positive
from hri_sync.ros.stamps import header, stamp
from hri_sync.ros.timers import wait_for
from hri_sync.clock.ros_synced_clock import SyncedClock
from hri_sync.client_process.health import client_tally
from hri_sync.wire.config import unknown
from hri_sync.client_process.liveness import Beat, Liveness
from hri_sync.client_process.schedule import ClientSchedule, Late
from hri_sync.wire.protocol import Capture
from hri_sync.wire.validate import Context
from hri_sync.wire.vocabulary import MAX_UNCERTAINTY, ResultStatus


class ClientProcess:
    """The ROS shell of ``hri_sync.wire.protocol.ClientSchedule``.

    Keeps a ``SyncedClock``; on ``sync_time`` measures and publishes the
    schedule's ACK or NACK (``~max_uncertainty``); turns ``capture_data``
    into ``on_capture(Scheduled)`` or ``on_late(Late)``.  Both topics
    are taken only from the CM and validated (``inbox``; a node may
    subscribe its own topics through it too).  Its health is on
    /diagnostics: ``clock``, ``rounds`` and ``input`` (the inbox's
    counts, and capture orders the schedule ignored; one for other
    clients is not counted).

    With ``liveness`` (a CPM with a DPM behind it) it ACKs only while
    that DPM's heartbeat (``dpm_state`` in its namespace) is at most
    ``~dpm_timeout`` s old, the DPM's node is connected to ``orders``
    (when given: the Publisher of its capture orders; a recorder's
    connection does not count), and its sensor's last sample at most
    ``~sensor_timeout`` s (<= 0: no sensor to watch); a failing check
    may turn within ``~liveness_wait`` s (a DPM starting) before the
    CPM NACKs with its reason.  With ``~sensor_driver`` (the sensor
    driver's node, e.g. ``tracker``), a silent sensor's reason adds what
    the driver last said (its latched ``~sensor_status``, the status it
    puts on /diagnostics).

    Nothing is ACKed or scheduled before ``start()``: a round that came
    while the node was still being built would run its callbacks on a
    half-made node.
    """

    def __init__(self, client_id, on_capture, on_late=None, inbox=None,
                 liveness=False, orders=None):
        self.client_id = client_id
        self.on_capture = on_capture
        self.on_late = on_late
        self.schedule = ClientSchedule(
            client_id, param('max_uncertainty', MAX_UNCERTAINTY, float,
                             positive, '> 0 s'))
        self.synced_clock = SyncedClock(client_id)
        self.clock = self.synced_clock.clock
        self._ack_pub = Publisher(protocol_topic('sync_ack'), SyncAck,
                                  queue_size=10)
        self.inbox = inbox if inbox is not None else Inbox()
        self._capture_topic = protocol_topic('capture_data')
        self.liveness = self._liveness(orders) if liveness else None
        self.tally = client_tally()
        self.diagnostics = round_diagnostics(
            client_id, self.tally, self.synced_clock,
            self.schedule.max_uncertainty)
        if self.liveness is not None:
            self.diagnostics.add('dpm', lambda: self.liveness.health(
                time.time()))
        self.diagnostics.rejections(self.inbox.summary, lambda: {
            self._capture_topic + ' ' + why: n
            for why, n in dict(self.schedule.ignored).items()
            if why != 'not_a_participant'})

    def start(self):
        """Subscribe ``sync_time`` and ``capture_data``: from here on the
        client ACKs and its callbacks may run (in rospy's threads), so a
        node calls it once the state they use is set (``self.cpm``
        assigned), last."""
        self.inbox.subscribe(protocol_topic('sync_time'), SyncTime,
                             self._on_sync_time, 'cm',
                             context=lambda: self.context(None),
                             queue_size=10)
        self.inbox.subscribe(self._capture_topic, CaptureData,
                             self._on_capture_data, 'cm',
                             context=lambda: self.context(
                                 self.schedule.acked_round),
                             queue_size=10)

    def _liveness(self, orders):
        """The liveness rule from ~params, fed by the DPM's heartbeat;
        with ``orders`` (the Publisher of the DPM's capture orders), the
        DPM listens once its node is connected to it."""
        dpm = self.inbox.senders.names('dpm', self.client_id)
        listening = None if orders is None else (
            lambda: any(orders.impl.has_connection(n) for n in dpm))
        sensor_timeout = param('sensor_timeout', 2.0, float)
        try:
            live = Liveness(param('dpm_timeout', 2.0, float),
                            sensor_timeout if sensor_timeout > 0 else None,
                            time.time(), listening)
        except ValueError as e:
            raise ParamError(str(e))
        self.liveness_wait = param('liveness_wait', 1.5, float,
                                   lambda x: x >= 0, '>= 0 s')

        def on_state(msg):
            live.on_beat(Beat(time.time(), msg.input, msg.samples,
                              msg.sample_age, msg.rate, msg.refused,
                              msg.refused_reason))
        self.inbox.subscribe(
            client_topic(self.client_id, 'dpm_state'), DpmState, on_state,
            'dpm',
            client=self.client_id,
            context=lambda: Context(local_now=time.time()), queue_size=1)
        driver = param('sensor_driver', '', str)
        if driver:      # the client's sensor role only; Liveness checks it
            self.inbox.subscribe(
                rospy.resolve_name(driver) + '/sensor_status',
                DiagnosticStatus, lambda st: live.on_driver_status(
                    time.time(), st.level, st.message), 'sensor',
                client=self.client_id, check=False, queue_size=1)
        return live

    def alive(self):
        """The liveness Verdict now (None without a check), waiting up to
        ~liveness_wait s for a failing one to turn."""
        if self.liveness is None:
            return None
        wait_for(lambda: self.liveness.verdict(time.time()).ok,
                 self.liveness_wait, poll=0.02)
        return self.liveness.verdict(time.time())

    def context(self, round_id):
        """The global now (when the clock is usable) and ``round_id``
        (None: any; the CM numbers the rounds), to judge the CM's
        messages against."""
        return Context(now=self.clock.now() if self.clock.ready else None,
                       round=round_id)

    def _on_sync_time(self, msg):
        received = time.time()
        status = self.synced_clock.measure()
        alive = self.alive()
        r = self.schedule.on_sync(msg.round, received, time.time(), status,
                                  alive)
        no_model = math.isnan(r.stamp)
        self._ack_pub.publish(SyncAck(
            # The core's NaN times: no clock model yet, so no time.
            header=header(None if no_model else r.stamp), round=r.round,
            client_id=r.client_id, ok=r.ok, reason=r.reason,
            offset=r.offset, uncertainty=r.uncertainty, drift=r.drift,
            sync_received=stamp(None if no_model else r.sync_received)))
        self.tally.record(r.round, 'acked' if r.ok else 'nacked', r.reason)
        if not r.ok:
            rospy.logerr('%s: NACK round %d: %s', self.client_id, msg.round,
                         r.reason)
        elif r.reason:
            rospy.logwarn('%s: ACK round %d in %s', self.client_id,
                          msg.round, r.reason)

    def _on_capture_data(self, msg):
        before = Counter(self.schedule.ignored)
        order = self.schedule.on_capture(Capture.from_msg(msg),
                                         self.clock.now(), self.clock)
        if order is None:
            why = ', '.join(self.schedule.ignored - before)
            if why == 'acked_not_a_participant':
                rospy.logwarn_once(
                    '%s: round %d went on without this client, which ACKed '
                    'it: the server has no such client (its ~clients), or '
                    'the ACK came late: %s', self.client_id, msg.round,
                    unknown('client', self.client_id, msg.clients))
            log = (rospy.loginfo if why == 'not_a_participant'
                   else rospy.logwarn)
            log('%s: capture_data of round %d ignored (%s); ignored so far: '
                '%s', self.client_id, msg.round, why,
                dict(self.schedule.ignored))
            return
        if isinstance(order, Late):
            self.tally.record(order.round, ResultStatus.LATE, order.reason)
            rospy.logerr('%s: %s', self.client_id, order.reason)
            if self.on_late:
                self.on_late(order)
            return
        self.tally.record(order.round, 'scheduled', 'order %.0f ms ahead of '
                          'the window' % (order.lead * 1e3))
        self.on_capture(order)
