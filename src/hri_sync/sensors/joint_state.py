"""sensor_msgs/JointState: mean squared joint speed (any kinematic chain,
a person's joint angles or a robot's)."""
import math

from hri_sync.sensors.base import HeaderStamped, finite
from hri_sync.data_process.processors import ProcessResult
from hri_sync.wire.validate import Rejected

SOURCES = ('position', 'velocity')
MAX_JOINTS = 1024


class JointSpeed(HeaderStamped):
    """Mean squared joint speed: the expressiveness idea (docs/
    dance_off.md) for any kinematic chain, averaged over its joints so
    chains of different sizes compare.

    ``source: position`` (default): each joint's position change between
    its consecutive samples, value = mean over joints of
    sum_k (q_k - q_(k-1))^2 / dt_k / T (T the window, s): the joint's
    time-averaged squared speed.  ``source: velocity``: the mean over
    samples and joints of the messages' ``velocity``^2.  Unit: rad^2/s^2
    (m^2/s^2 for a prismatic joint).  Joints are matched by name, so
    their order may change between messages; ``joints`` (a list of names,
    default all) picks some.

    Rejected at the boundary: names not unique or empty, a ``position``
    (or ``velocity``) whose length is not the names', a NaN or infinite
    value in the field used.
    """

    msg_type = 'sensor_msgs/JointState'
    topic = 'joint_states'

    def __init__(self, source='position', joints=None):
        super().__init__()
        if source not in SOURCES:
            raise ValueError('source must be one of %s, got %r'
                             % (', '.join(SOURCES), source))
        self.source = source
        self.joints = None if joints is None else set(map(str, joints))
        self.begin(0.0, 0.0)

    def check(self, msg):
        names = list(msg.name)
        if not names or len(names) > MAX_JOINTS:
            raise Rejected('wrong_length', '%d joint names (1..%d)'
                           % (len(names), MAX_JOINTS), 'name')
        if len(set(names)) != len(names):
            raise Rejected('malformed', 'a joint name repeats', 'name')
        values = getattr(msg, self.source)
        if len(values) != len(names):
            raise Rejected('wrong_length', '%d %s values for %d names'
                           % (len(values), self.source, len(names)),
                           self.source)
        finite(values, self.source)

    def begin(self, start, end):
        self._duration = end - start
        self._last = {}          # name: (stamp, position)
        self._sum = {}           # name: sum of squared speed terms
        self._count = {}         # name: terms
        self._frames = 0
        self._unused = 0

    def add(self, frame):
        values = getattr(frame.msg, self.source)
        used = False
        for name, v in zip(frame.msg.name, values):
            if self.joints is not None and name not in self.joints:
                continue
            used = True
            if self.source == 'velocity':
                term = v * v
            else:
                last = self._last.get(name)
                self._last[name] = (frame.stamp, v)
                if last is None or frame.stamp <= last[0]:
                    self._sum.setdefault(name, 0.0)
                    continue
                term = (v - last[1]) ** 2 / (frame.stamp - last[0])
            self._sum[name] = self._sum.get(name, 0.0) + term
            self._count[name] = self._count.get(name, 0) + 1
        self._frames += used
        self._unused += not used

    def result(self):
        joints = len(self._sum)
        if not joints:
            value = math.nan
        elif self.source == 'velocity':
            value = sum(self._sum[j] / self._count[j] for j in self._count
                        ) / joints
        else:
            value = (sum(self._sum.values()) / joints / self._duration
                     if self._duration > 0 else 0.0)
        return ProcessResult(
            value=value, frames_used=self._frames,
            frames_rejected=self._unused,
            diagnostics={'joints': joints, 'source': self.source,
                         'frames_without_selected_joints': self._unused,
                         'unit': 'rad^2/s^2'})
