#!/usr/bin/python3
"""Makes the compact sensor recordings of data/sensors/ (docs/sensors.md).

    /usr/bin/python3 scripts/make_sensor_data.py [--speech]

From the repo's motion clips (data/motion/, converted CMU motion capture):

- camera_dancer.bag: /camera/depth/image_raw, sensor_msgs/Image 16UC1,
  160x120 at 15 Hz for 10 s: the salsa dancer cmu_60_01 rendered as a depth
  image (limbs as 12 cm thick capsules, a wall at 4 m), bz2-compressed;
- imu_wrist.bag: /imu/data, sensor_msgs/Imu at 100 Hz for 18 s: an IMU on
  the dancer's right wrist (its axes the sensor frame's: x right, y up, z
  away), the specific force (acceleration minus gravity) and the
  forearm's angular rate, from the motion by finite differences;
- joints_dancer.bag: /joint_states, sensor_msgs/JointState at 30 Hz for
  18 s: the dancer's elbow, shoulder, hip and knee angles (rad).

With --speech, also speech.wav (16 kHz mono, 16-bit) spoken by espeak-ng
(needs the espeak-ng package; the WAV is shipped, so only its maker needs
it).  Every message's header.stamp starts at 1000 s (the replay restamps).
"""
import argparse
import os
import subprocess
import sys
import tempfile

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, 'src'))

from hri_sync.dance_off.joints import INDEX  # noqa: E402
from hri_sync.dance_off.motion import load_motion  # noqa: E402

OUT = os.path.join(ROOT, 'data', 'sensors')
T0 = 1000.0
CLIP = os.path.join(ROOT, 'data', 'motion', 'cmu_60_01_salsa.npz')
BONES = [('head', 'neck'), ('neck', 'torso'), ('left_shoulder',
                                               'right_shoulder'),
         ('left_shoulder', 'left_elbow'), ('left_elbow', 'left_hand'),
         ('right_shoulder', 'right_elbow'), ('right_elbow', 'right_hand'),
         ('torso', 'left_hip'), ('torso', 'right_hip'),
         ('left_hip', 'right_hip'), ('left_hip', 'left_knee'),
         ('left_knee', 'left_foot'), ('right_hip', 'right_knee'),
         ('right_knee', 'right_foot')]
SPEECH = ('Hello. I am the audio client of the dance off. '
          'Every sensor here shares one clock. '
          'Can you hear me, DJ Rob? Let us dance.')


def header(msg, t, frame_id):
    import rospy
    msg.header.stamp = rospy.Time.from_sec(T0 + t)
    msg.header.frame_id = frame_id
    return msg


def render_depth(pos, width=160, height=120, hfov=57.0, wall=4.0,
                 radius=0.06):
    """A 16UC1 depth image (mm) of one frame's joints (15, 3), sensor
    frame: a pinhole camera at the origin looking along +z."""
    f = 0.5 * width / np.tan(np.radians(hfov / 2))
    depth = np.full((height, width), wall * 1000.0)
    vv, uu = np.mgrid[0:height, 0:width]
    for a, b in BONES:
        pa, pb = pos[INDEX[a]], pos[INDEX[b]]
        for s in np.linspace(0.0, 1.0, 8):
            x, y, z = pa + s * (pb - pa)
            if z <= 0.3:
                continue
            u, v = width / 2 + f * x / z, height / 2 - f * y / z
            r = f * radius / z
            disc = (uu - u) ** 2 + (vv - v) ** 2 <= r * r
            np.minimum(depth, np.where(disc, z * 1000.0, np.inf), out=depth)
    return depth.astype(np.uint16)


def camera(motion, path, rate=15.0, dur=10.0):
    import rosbag
    from sensor_msgs.msg import Image
    times = np.arange(int(rate * dur)) / rate
    frames = motion.positions_at(times + motion.times[0])
    with rosbag.Bag(path, 'w', compression='bz2') as bag:
        for t, pos in zip(times, frames):
            d = render_depth(pos)
            msg = header(Image(height=d.shape[0], width=d.shape[1],
                               encoding='16UC1', is_bigendian=0,
                               step=2 * d.shape[1], data=d.tobytes()),
                         t, 'camera_depth_optical_frame')
            bag.write('/camera/depth/image_raw', msg, msg.header.stamp)


def imu(motion, path, rate=100.0):
    import rosbag
    from sensor_msgs.msg import Imu
    dt = 1.0 / rate
    times = np.arange(int(motion.duration * rate) - 2) * dt
    p = motion.positions_at(times + motion.times[0], 'clamp')
    # The clip is linear between its 60 Hz frames: smooth over ~70 ms
    # (two passes of a 7-sample box) before differentiating twice.
    box = np.ones(7) / 7
    for _ in range(2):
        p = np.apply_along_axis(np.convolve, 0, p, box, mode='same')
    p, times = p[10:-10], times[10:-10] - times[10]
    hand, elbow = p[:, INDEX['right_hand']], p[:, INDEX['right_elbow']]
    acc = np.gradient(np.gradient(hand, dt, axis=0), dt, axis=0)
    acc[:, 1] += 9.81                  # at rest it reads +g, up
    u = hand - elbow
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    omega = np.cross(u, np.gradient(u, dt, axis=0))
    with rosbag.Bag(path, 'w', compression='bz2') as bag:
        for t, a, w in zip(times, acc, omega):
            msg = header(Imu(), t, 'right_wrist_imu')
            msg.orientation_covariance[0] = -1.0    # no orientation
            (msg.linear_acceleration.x, msg.linear_acceleration.y,
             msg.linear_acceleration.z) = a
            (msg.angular_velocity.x, msg.angular_velocity.y,
             msg.angular_velocity.z) = w
            bag.write('/imu/data', msg, msg.header.stamp)


def angle(a, b, c):
    """The angle at b (rad) between b->a and b->c, per frame."""
    u, v = a - b, c - b
    cos = np.sum(u * v, axis=1) / (np.linalg.norm(u, axis=1)
                                   * np.linalg.norm(v, axis=1))
    return np.arccos(np.clip(cos, -1.0, 1.0))


def joints(motion, path, rate=30.0):
    import rosbag
    from sensor_msgs.msg import JointState
    times = np.arange(int(motion.duration * rate) - 1) / rate
    p = motion.positions_at(times + motion.times[0], 'clamp')
    j = {n: p[:, i] for n, i in INDEX.items()}
    names, values = [], []
    for side in ('left', 'right'):
        s = side + '_'
        names += [s + 'elbow', s + 'shoulder', s + 'hip', s + 'knee']
        values += [angle(j[s + 'shoulder'], j[s + 'elbow'], j[s + 'hand']),
                   angle(j['torso'], j[s + 'shoulder'], j[s + 'elbow']),
                   angle(j['torso'], j[s + 'hip'], j[s + 'knee']),
                   angle(j[s + 'hip'], j[s + 'knee'], j[s + 'foot'])]
    values = np.stack(values, axis=1)
    with rosbag.Bag(path, 'w', compression='bz2') as bag:
        for t, q in zip(times, values):
            msg = header(JointState(name=names, position=q.tolist()), t, '')
            bag.write('/joint_states', msg, msg.header.stamp)


def speech(path, rate=16000):
    """espeak-ng's speech, resampled to ``rate``, 1 s of silence around."""
    import wave
    with tempfile.TemporaryDirectory() as tmp:
        raw = os.path.join(tmp, 'speech.wav')
        subprocess.run(['espeak-ng', '-s', '140', '-w', raw, SPEECH],
                       check=True)
        with wave.open(raw, 'rb') as w:
            src = w.getframerate()
            x = np.frombuffer(w.readframes(w.getnframes()), '<i2')
    t = np.arange(int(len(x) * rate / src)) / rate
    y = np.interp(t, np.arange(len(x)) / src, x.astype(float))
    pad = np.zeros(rate)
    y = np.concatenate((pad, y, pad)).astype('<i2')
    with wave.open(path, 'wb') as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(rate)
        w.writeframes(y.tobytes())


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('--speech', action='store_true',
                        help='also speak speech.wav (needs espeak-ng)')
    opts = parser.parse_args()
    os.makedirs(OUT, exist_ok=True)
    motion = load_motion(CLIP)
    camera(motion, os.path.join(OUT, 'camera_dancer.bag'))
    imu(motion, os.path.join(OUT, 'imu_wrist.bag'))
    joints(motion, os.path.join(OUT, 'joints_dancer.bag'))
    if opts.speech:
        speech(os.path.join(OUT, 'speech.wav'))
    for name in sorted(os.listdir(OUT)):
        print('%8d B  data/sensors/%s' % (
            os.path.getsize(os.path.join(OUT, name)), name))


if __name__ == '__main__':
    main()
