"""Any message with a std_msgs/Header: captured, recorded and counted."""
from hri_sync.sensors.base import HeaderStamped
from hri_sync.data_process.processors import ProcessResult


class HeaderCount(HeaderStamped):
    """Synchronizes a sensor nobody wrote a processor for: its messages
    are stamped (their ``header.stamp`` mapped to global time, or their
    arrival with ``stamp_source: arrival``), captured in the window and
    republished on ``captured`` (record that topic), and counted.

    ``~processor_params``: ``msg_type``, the ROS type (e.g.
    ``sensor_msgs/LaserScan``; required, it must start with a
    std_msgs/Header).  The DPM reads ``input`` (remap it).  value = the
    number of messages in the window; the diagnostics give their rate
    (Hz over the window).
    """

    topic = 'input'

    def __init__(self, msg_type=''):
        super().__init__()
        if not isinstance(msg_type, str) or msg_type.count('/') != 1:
            raise ValueError("msg_type must name a ROS message type like "
                             "'sensor_msgs/LaserScan', got %r" % (msg_type,))
        self.msg_type = msg_type
        self.begin(0.0, 0.0)

    def begin(self, start, end):
        self._duration = end - start
        self._n = 0

    def add(self, frame):
        self._n += 1

    def result(self):
        return ProcessResult(
            value=float(self._n), frames_used=self._n,
            diagnostics={'msg_type': self.msg_type, 'unit': 'messages',
                         'rate': (self._n / self._duration
                                  if self._duration > 0 else 0.0)})
