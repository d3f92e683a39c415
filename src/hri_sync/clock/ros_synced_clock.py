"""A host's global clock kept against the time server, as a ROS object."""
import subprocess
import threading
import time

import rospy

from hri_sync.msg import ClockState
from hri_sync.clock.ros_clock_state import msg_from_model
from hri_sync.ros.names import client_topic
from hri_sync.ros.outbox import closed_at_shutdown
from hri_sync.ros.params import param, positive
from hri_sync.ros.timers import wait_for
from hri_sync.clock import ntp
from hri_sync.clock.model import DRIFT_BOUND
from hri_sync.clock.sync import ClockSync, SyncError


class SyncedClock:
    """The ROS shell of a ``ClockSync``: params, chronyc, the publisher.

    Reads ``~ntp_server``, ``~ntp_port``, ``~ntp_exchanges``,
    ``~ntp_timeout``, ``~resync_period``, ``~drift_bound`` and
    ``~sync_method``; runs the resync loop in a thread and publishes the
    model latched on ``NS/<name>/clock_state`` (hri_sync/ClockState) after
    every measurement.  The local clock is ``time.time``.
    """

    def __init__(self, name):
        self.name = name
        self.server = param('ntp_server', '127.0.0.1', str)
        self.port = param('ntp_port', 11123, int,
                          lambda p: 0 < p < 65536, 'a UDP port')
        self.exchanges = param('ntp_exchanges', 8, int, lambda n: n >= 1,
                               'at least one exchange')
        self.timeout = param('ntp_timeout', 0.5, float, positive, '> 0 s')
        self.sync_method = param(
            'sync_method', 'software', str,
            lambda m: m in ('software', 'step'), "'software' or 'step'")
        self.sync = ClockSync(
            self._measure, time.time,
            resync_period=param('resync_period', 5.0, float, positive,
                                '> 0 s'),
            drift_bound=param('drift_bound', DRIFT_BOUND, float,
                              lambda x: 0 <= x < 1, '>= 0 s/s'))
        self.clock = self.sync.clock
        self._publish_lock = threading.Lock()
        self._state_pub = rospy.Publisher(client_topic(name, 'clock_state'),
                                          ClockState, queue_size=1,
                                          latch=True)
        threading.Thread(target=self.sync.run, daemon=True,
                         args=(time.sleep, rospy.is_shutdown,
                               self._report)).start()

    @property
    def last_error(self):
        """Why the last measurement failed ('' if it succeeded)."""
        return self.sync.last_error

    def measure(self):
        """One NTP burst into the clock model; publishes and returns the
        ClockStatus."""
        status = self.sync.sync()
        self._publish()
        return status

    def wait_ready(self, timeout):
        """Block until the first measurement succeeded; False on timeout."""
        return wait_for(lambda: self.clock.ready, timeout, 0.05)

    def _measure(self):
        if self.sync_method == 'step':
            try:
                subprocess.run(['chronyc', 'makestep'], check=True,
                               timeout=5, capture_output=True)
            except (OSError, subprocess.SubprocessError) as e:
                raise SyncError('chronyc makestep failed: %s' % e)
        return ntp.measure(self.server, self.port, self.exchanges,
                           self.timeout, local_clock=time.time)

    def _publish(self):
        # The latest status: the loop and a sync_time may measure at
        # once, and the latched state must never go back.
        with self._publish_lock:
            status = self.sync.status()
            local = time.time()
            with closed_at_shutdown():
                self._state_pub.publish(msg_from_model(
                    self.name, status.model.snapshot(local),
                    status.reason(local), status.samples, status.round_trip))

    def _report(self, status):
        self._publish()
        if status.error:
            rospy.logwarn_throttle(10, '%s: clock sync failed: %s'
                                   % (self.name, status.error))
