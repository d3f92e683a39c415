#!/usr/bin/python3
"""A mixed-sensor round (launch/sensors.launch joints:=true generic:=true):
every stock processor used, bad input injected on every new path.

The six clients (skeleton, imu, audio, camera, joints, and generic, which
counts the IMU's stream with HeaderCount; each on its own
skewed clock) capture one window, started on the CM's service once every
client's sensor delivers.  In its middle this checker publishes,
on the clients' input topics, ~bad messages of each kind: an image whose
data does not match step x height, one of an unknown encoding, an IMU
sample with a NaN acceleration, a joint state with a NaN position, an
empty audio chunk and an odd-length stereo one.  Each client must then
report ok with a value in its physical range, and count exactly the bad
messages sent to it by reason in its result (``invalid_<reason>``), and
on /diagnostics (``<topic> <reason>``).
"""
import math
import threading
import time
import unittest

import rospy
import rostest
from diagnostic_msgs.msg import DiagnosticArray
from sensor_msgs.msg import Image, Imu, JointState

from hri_sync.msg import AudioChunk, CaptureData, ClientResult, Decision
from hri_sync.ros.node import init_checker
from hri_sync.ros.replay import start_round_when_delivering
from hri_sync.wire.protocol import Capture

# client: (low, high) of a plausible value of the replayed recording
RANGES = {'skeleton': (1.0, 1e4), 'imu': (1.0, 200.0), 'audio': (0.1, 0.95),
          'camera': (0.05, 50.0), 'joints': (0.1, 1e3),
          # HeaderCount of the 100 Hz IMU stream over 5 s (+ the bad ones)
          'generic': (450.0, 550.0)}


def bad_messages():
    """[(client, topic, message class, message, reason)]."""
    img = Image(height=4, width=4, encoding='16UC1', step=8, data=b'\0' * 31)
    yuv = Image(height=4, width=4, encoding='yuv422', step=8, data=b'\0' * 32)
    imu = Imu()
    imu.linear_acceleration.x = math.nan
    joints = JointState(name=['a', 'b'], position=[0.0, math.nan])
    empty = AudioChunk(sample_rate=16000, channels=1, data=[])
    odd = AudioChunk(sample_rate=16000, channels=2, data=[1, 2, 3])
    return [('camera', '/camera/image', Image, img, 'size_mismatch'),
            ('camera', '/camera/image', Image, yuv, 'unknown_encoding'),
            ('imu', '/imu/imu', Imu, imu, 'not_finite'),
            ('joints', '/joints/joint_states', JointState, joints,
             'not_finite'),
            ('audio', '/audio/audio', AudioChunk, empty, 'empty'),
            ('audio', '/audio/audio', AudioChunk, odd, 'wrong_length')]


class SensorsRound(unittest.TestCase):

    def setUp(self):
        self.lock = threading.Lock()
        self.results, self.decisions, self.captures = {}, [], []
        self.diag = {}
        rospy.Subscriber('/client_result', ClientResult, self.on_result)
        rospy.Subscriber('/decision', Decision,
                         lambda m: self.decisions.append(m))
        rospy.Subscriber('/capture_data', CaptureData,
                         lambda m: self.captures.append(m))
        rospy.Subscriber('/diagnostics', DiagnosticArray, self.on_diag)
        self.bad = bad_messages()
        self.pubs = {}
        for _, topic, cls, _, _ in self.bad:
            if topic not in self.pubs:
                self.pubs[topic] = rospy.Publisher(topic, cls, queue_size=50)

    def on_result(self, msg):
        with self.lock:
            self.results[msg.client_id] = msg

    def on_diag(self, msg):
        with self.lock:
            for s in msg.status:
                for kv in s.values:
                    self.diag[kv.key] = kv.value

    def wait(self, predicate, timeout):
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline and not rospy.is_shutdown():
            if predicate():
                return True
            time.sleep(0.05)
        return predicate()

    def test_round(self):
        n = rospy.get_param('~bad', 4)
        # The service returns when the round is over: in a thread.
        threading.Thread(target=start_round_when_delivering,
                         args=(sorted(RANGES), 200.0), daemon=True).start()
        self.assertTrue(self.wait(lambda: self.captures, 260.0),
                        'no capture_data: the round never started')
        window = Capture.from_msg(self.captures[0])
        # The middle of the window, on the host clock (global within ms).
        t = window.start + 0.2 * (window.end - window.start)
        time.sleep(max(0.0, t - time.time()))
        for _ in range(n):
            for _, topic, _, msg, _ in self.bad:
                msg.header.stamp = rospy.Time.from_sec(time.time())
                self.pubs[topic].publish(msg)
            time.sleep(0.5 * (window.end - window.start) / n)
        self.assertTrue(self.wait(lambda: len(self.results) == len(RANGES)
                                  and self.decisions, 60.0),
                        'results of %s only' % sorted(self.results))
        failures = []
        for client, (lo, hi) in sorted(RANGES.items()):
            r = self.results[client]
            d = {kv.key: kv.value for kv in r.diagnostics}
            rospy.loginfo('%s: %s value %.4g %s, %d frames (%d rejected), '
                          'coverage %.2f', client, r.status, r.value,
                          d.get('unit', ''), r.frames, r.frames_rejected,
                          r.coverage)
            if r.status != ClientResult.OK:
                failures.append('%s: status %s (%s)' % (
                    client, r.status, d.get('error', '')))
            if not lo <= r.value <= hi:
                failures.append('%s: value %r outside [%g, %g]'
                                % (client, r.value, lo, hi))
            sent = {}
            for c, topic, _, _, reason in self.bad:
                if c == client:
                    sent[(topic, reason)] = n
            for (topic, reason), count in sent.items():
                got = int(d.get('invalid_' + reason, 0))
                if got != count:
                    failures.append('%s: %d %s counted in the result, %d '
                                    'sent' % (client, got, reason, count))
                self.wait(lambda: int(self.diag.get(
                    '%s %s' % (topic, reason), 0)) >= count, 10.0)
                on_diag = int(self.diag.get('%s %s' % (topic, reason), 0))
                if on_diag < count:
                    failures.append('%s: /diagnostics has %d of %s on %s, '
                                    '%d sent' % (client, on_diag, reason,
                                                 topic, count))
            if sent and r.frames_rejected < sum(sent.values()):
                failures.append('%s: frames_rejected %d < %d sent bad'
                                % (client, r.frames_rejected,
                                   sum(sent.values())))
        self.assertEqual(failures, [])


if __name__ == '__main__':
    init_checker('sensors_check')
    rostest.rosrun('hri_sync', 'sensors_round', SensorsRound)
