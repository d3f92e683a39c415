"""The client process module (CPM) on ROS: ACKs and capture orders."""
import math
import time
from collections import Counter

import rospy

from hri_sync.msg import CaptureData, SyncAck, SyncTime
from hri_sync.ros.params import param, positive, secs, stamp
from hri_sync.ros.synced_clock import SyncedClock
from hri_sync.timing.protocol import Capture, ClientSchedule, Late


class ClientProcess:
    """The client process module: a global clock, ACKs and the schedule.

    Keeps a ``SyncedClock``, ACKs ``/sync_time`` after a fresh measurement
    (or NACKs with the reason, also when the uncertainty exceeds
    ``~max_uncertainty``) and turns ``/capture_data`` into
    ``on_capture(Scheduled)`` or ``on_late(Late)``.
    """

    def __init__(self, client_id, on_capture, on_late=None):
        self.client_id = client_id
        self.on_capture = on_capture
        self.on_late = on_late
        self.max_uncertainty = param('max_uncertainty', 0.005, float,
                                     positive, '> 0 s')
        self.synced = SyncedClock(client_id)
        self.clock = self.synced.clock
        self.schedule = ClientSchedule(client_id)
        self._ack_pub = rospy.Publisher('/sync_ack', SyncAck, queue_size=10)
        rospy.Subscriber('/sync_time', SyncTime, self._on_sync_time,
                         queue_size=10)
        rospy.Subscriber('/capture_data', CaptureData, self._on_capture_data,
                         queue_size=10)

    def _on_sync_time(self, msg):
        local_rx = time.time()
        error = self.synced.measure()
        ok, reason = error is None, error or ''
        if ok and self.clock.uncertainty > self.max_uncertainty:
            ok = False
            reason = ('offset uncertainty %.2f ms exceeds ~max_uncertainty '
                      '%.2f ms' % (self.clock.uncertainty * 1e3,
                                   self.max_uncertainty * 1e3))
        self.schedule.on_sync(msg.round, ok)
        now = time.time()
        synced = self.clock.synced
        self._ack_pub.publish(SyncAck(
            round=msg.round, client_id=self.client_id, ok=ok, reason=reason,
            offset=self.clock.offset_at(now) if synced else math.nan,
            uncertainty=self.clock.uncertainty if synced else math.nan,
            drift=self.clock.drift,
            sync_received=stamp(self.clock.to_global(local_rx)
                                if synced else math.nan),
            stamp=stamp(self.clock.to_global(now) if synced else math.nan)))
        if not ok:
            rospy.logerr('%s: NACK round %d: %s', self.client_id, msg.round,
                         reason)

    def _on_capture_data(self, msg):
        capture = Capture(msg.round, secs(msg.cr_t), msg.str_aft, msg.dur,
                          list(msg.clients))
        before = Counter(self.schedule.ignored)
        order = self.schedule.on_capture(capture, self.clock.now(), self.clock)
        if order is None:
            why = ', '.join(self.schedule.ignored - before)
            log = (rospy.loginfo if why == 'not_a_participant'
                   else rospy.logwarn)
            log('%s: capture_data of round %d ignored (%s); ignored so far: '
                '%s', self.client_id, msg.round, why,
                dict(self.schedule.ignored))
            return
        if isinstance(order, Late):
            rospy.logerr('%s: %s', self.client_id, order.reason)
            if self.on_late:
                self.on_late(order)
            return
        self.on_capture(order)
