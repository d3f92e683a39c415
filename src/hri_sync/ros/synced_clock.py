"""A host's global clock kept against the time server, as a ROS object."""
import subprocess
import threading
import time

import rospy

from hri_sync.msg import ClockState
from hri_sync.ros.params import param, positive, wait_for
from hri_sync.timing import ntp
from hri_sync.timing.clock import GlobalClock


class SyncedClock:
    """A host's global clock, kept against the time server.

    Reads ``~ntp_server``, ``~ntp_port``, ``~ntp_exchanges``,
    ``~ntp_timeout``, ``~resync_period`` and ``~sync_method``; re-measures
    every resync period in a thread and publishes the model latched on
    ``/<name>/clock_state`` (hri_sync/ClockState).
    """

    def __init__(self, name):
        self.name = name
        self.server = param('ntp_server', '127.0.0.1', str)
        self.port = param('ntp_port', 11123, int,
                          lambda p: 0 < p < 65536, 'a UDP port')
        self.exchanges = param('ntp_exchanges', 8, int, lambda n: n >= 1,
                               'at least one exchange')
        self.timeout = param('ntp_timeout', 0.5, float, positive, '> 0 s')
        self.resync_period = param('resync_period', 5.0, float, positive,
                                   '> 0 s')
        self.sync_method = param(
            'sync_method', 'software', str,
            lambda m: m in ('software', 'step'), "'software' or 'step'")
        self.clock = GlobalClock()
        self.last_error = 'not measured yet'
        self._lock = threading.Lock()
        self._state_pub = rospy.Publisher('/%s/clock_state' % name,
                                          ClockState, queue_size=1,
                                          latch=True)
        threading.Thread(target=self._resync_loop, daemon=True).start()

    def measure(self):
        """One NTP burst into the clock model; returns an error or None."""
        with self._lock:
            try:
                if self.sync_method == 'step':
                    subprocess.run(['chronyc', 'makestep'], check=True,
                                   timeout=5, capture_output=True)
                m = ntp.measure(self.server, self.port, self.exchanges,
                                self.timeout)
            except (ntp.NtpError, OSError, subprocess.SubprocessError) as e:
                self.last_error = str(e)
                self._publish_state(False, self.last_error)
                return self.last_error
            self.clock.add(m)
            self.last_error = ''
            self._publish_state(True, '')
            return None

    def wait_synced(self, timeout):
        """Block until the first measurement succeeded; False on timeout."""
        return wait_for(lambda: self.clock.synced, timeout, 0.05)

    def _publish_state(self, ok, reason):
        s = self.clock.state()
        self._state_pub.publish(ClockState(
            client_id=self.name, ok=ok and self.clock.synced,
            reason=reason, local_ref=s['local_ref'], offset=s['offset'],
            drift=s['drift'], uncertainty=min(s['uncertainty'], 1e9),
            samples=s['samples']))

    def _resync_loop(self):
        # Re-measure after 0.5, 1, 2, 4 s at start, so the drift is known
        # within seconds instead of one resync period.
        pause = 0.5
        while not rospy.is_shutdown():
            error = self.measure()
            if error:
                rospy.logwarn_throttle(10, '%s: clock sync failed: %s'
                                       % (self.name, error))
            time.sleep(min(pause, self.resync_period))
            pause *= 2
