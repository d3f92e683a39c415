"""sensor_msgs/Imu: activity over a window."""
import math

import numpy as np

from hri_sync.sensors.base import HeaderStamped, xyz
from hri_sync.data_process.processors import ProcessResult
from hri_sync.wire.validate import Rejected

MEASURES = ('acceleration', 'angular_rate')
MAX_ACCELERATION = 2000.0   # m/s^2 (200 g): beyond any wearable's range
MAX_ANGULAR_RATE = 200.0    # rad/s


class ImuActivity(HeaderStamped):
    """Activity of an IMU stream.

    ``measure: acceleration`` (default): the RMS deviation of the
    acceleration vector from its mean over the window, in m/s^2,
    sqrt(mean |a - mean(a)|^2): gravity and a constant bias drop out, a
    still sensor scores its noise, a shaken one more.  ``measure:
    angular_rate``: the RMS angular rate sqrt(mean |w|^2), rad/s.  Both
    are in the diagnostics (``acceleration_rms``, ``angular_rate_rms``).
    A sample with a NaN or infinite acceleration or angular rate, or one
    beyond 2000 m/s^2 or 200 rad/s, is rejected at the boundary; the
    orientation is not used (many IMUs do not give one) nor checked.
    """

    msg_type = 'sensor_msgs/Imu'
    topic = 'imu'

    def __init__(self, measure='acceleration'):
        super().__init__()
        if measure not in MEASURES:
            raise ValueError('measure must be one of %s, got %r'
                             % (', '.join(MEASURES), measure))
        self.measure = measure
        self.begin(0.0, 0.0)

    def check(self, msg):
        a = xyz(msg.linear_acceleration, 'linear_acceleration')
        w = xyz(msg.angular_velocity, 'angular_velocity')
        for what, v, hi in (('linear_acceleration', a, MAX_ACCELERATION),
                            ('angular_velocity', w, MAX_ANGULAR_RATE)):
            if math.sqrt(sum(c * c for c in v)) > hi:
                raise Rejected('out_of_range', '|%s| is beyond %g'
                               % (what, hi), what)

    def begin(self, start, end):
        self._n = 0
        self._sum_a = np.zeros(3)
        self._sum_a2 = 0.0
        self._sum_w2 = 0.0

    def add(self, frame):
        a = frame.msg.linear_acceleration
        w = frame.msg.angular_velocity
        a = np.array((a.x, a.y, a.z))
        self._n += 1
        self._sum_a += a
        self._sum_a2 += float(a @ a)
        self._sum_w2 += w.x * w.x + w.y * w.y + w.z * w.z

    def result(self):
        n = self._n
        if n:
            mean = self._sum_a / n
            acc = math.sqrt(max(0.0, self._sum_a2 / n - float(mean @ mean)))
            rate = math.sqrt(self._sum_w2 / n)
        else:
            acc = rate = math.nan
        return ProcessResult(
            value=acc if self.measure == 'acceleration' else rate,
            frames_used=n,
            diagnostics={'measure': self.measure, 'acceleration_rms': acc,
                         'angular_rate_rms': rate,
                         'unit': 'm/s^2' if self.measure == 'acceleration'
                         else 'rad/s'})
