#!/usr/bin/env python3
"""Make the small skeleton bags of test/bags/ from the motion in data/motion.

Each bag holds one hri_sync/Skeleton stream on /skeleton, as a 20 Hz tracker
would give it (hri_sync.dance_off.skeleton_source: own phase, white tracker
noise of 3 mm per axis), stamped from 0 (device_stamp = header.stamp), 20 s
long, bz2-compressed. The rostests replay them with skeleton_sensor ~bag. Cases
(the paper's pilot and validation):

  still_walker    cmu_131_01_walk held at its first frame (standing)
  still_salsa     cmu_61_01_salsa held at its first frame
  small_moves     cmu_60_01_salsa at 0.3x speed from 3 s (small movements)
  dancer_60_01    cmu_60_01_salsa at full speed (leader)
  dancer_61_01    cmu_61_01_salsa at full speed (follower, same take)

Needs the ``rosbags`` library (``make venv``; run with .venv/bin/python)
but no ROS build: message types come from msg/*.msg. Deterministic (fixed
seeds), so regenerating gives identical bags.
"""
import argparse
import os
import sys

import numpy as np
from rosbags.rosbag1 import Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, 'src'))

from hri_sync.dance_off.motion import load_motion  # noqa: E402
from hri_sync.dance_off.skeleton_source import SkeletonSource, tick_times  # noqa: E402

CASES = {
    'still_walker': ('cmu_131_01_walk', dict(hold=0.0), 1),
    'still_salsa': ('cmu_61_01_salsa', dict(hold=0.0), 2),
    'small_moves': ('cmu_60_01_salsa', dict(speed=0.3, offset=3.0), 3),
    'dancer_60_01': ('cmu_60_01_salsa', dict(), 4),
    'dancer_61_01': ('cmu_61_01_salsa', dict(), 5),
}
MAX_BYTES = 2 * 1024 * 1024


def typestore():
    store = get_typestore(Stores.ROS1_NOETIC)
    with open(os.path.join(ROOT, 'msg', 'Skeleton.msg')) as f:
        store.register(get_types_from_msg(f.read(), 'hri_sync/msg/Skeleton'))
    return store


def make_bag(path, name, kwargs, seed, dur, rate, noise, store):
    motion = load_motion(os.path.join(ROOT, 'data', 'motion', name + '.npz'))
    rng = np.random.default_rng(seed)
    source = SkeletonSource(motion, noise=noise, seed=seed, **kwargs)
    phase = rng.uniform(0, 1.0 / rate)
    frames = source.frames(tick_times(0.0, phase, rate, 0.0, dur), 0.0)
    write_bag(path, frames.stamps, frames.positions, frames.confidence,
              store, frames.orientations)
    return len(frames.stamps)


def ros_time(store, stamp):
    """A builtin Time of ``stamp`` s."""
    sec = int(np.floor(stamp))
    return store.types['builtin_interfaces/msg/Time'](
        sec=sec, nanosec=min(999999999, int(round((stamp - sec) * 1e9))))


def write_bag(path, stamps, positions, confidence, store, orientations=None,
              topic='/skeleton', frame_id='sensor'):
    """A bz2 bag of hri_sync/Skeleton frames on ``topic``: header.stamp =
    device_stamp = ``stamps`` (s), ``positions`` (N, 15, 3),
    ``confidence`` (N, 15), ``orientations`` (N, 15, 4; default
    identity)."""
    t = store.types
    Skeleton = t['hri_sync/msg/Skeleton']
    Header = t['std_msgs/msg/Header']
    Point = t['geometry_msgs/msg/Point']
    Quaternion = t['geometry_msgs/msg/Quaternion']
    if orientations is None:
        orientations = np.zeros(positions.shape[:2] + (4,))
        orientations[..., 3] = 1.0
    if os.path.exists(path):
        os.remove(path)
    writer = Writer(path)
    writer.set_compression(Writer.CompressionFormat.BZ2)
    with writer:
        conn = writer.add_connection(topic, 'hri_sync/msg/Skeleton',
                                     typestore=store)
        for k, stamp in enumerate(stamps):
            when = ros_time(store, stamp)
            msg = Skeleton(
                header=Header(seq=k, stamp=when, frame_id=frame_id),
                client_id='', user_id=1, device_stamp=when,
                positions=[Point(x=float(p[0]), y=float(p[1]), z=float(p[2]))
                           for p in positions[k]],
                orientations=[Quaternion(x=float(q[0]), y=float(q[1]),
                                         z=float(q[2]), w=float(q[3]))
                              for q in orientations[k]],
                confidence=np.asarray(confidence[k], dtype=np.float32))
            writer.write(conn, when.sec * 10**9 + when.nanosec,
                         store.serialize_ros1(msg, 'hri_sync/msg/Skeleton'))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--out', default=os.path.join(ROOT, 'test', 'bags'))
    parser.add_argument('--dur', type=float, default=20.0,
                        help='stream length, s (default %(default)s)')
    parser.add_argument('--rate', type=float, default=20.0)
    parser.add_argument('--noise', type=float, default=0.003)
    parser.add_argument('cases', nargs='*', default=sorted(CASES),
                        help='default: all of %s' % ', '.join(sorted(CASES)))
    args = parser.parse_args()
    store = typestore()
    os.makedirs(args.out, exist_ok=True)
    status = 0
    for case in args.cases:
        if case not in CASES:
            sys.exit('make_test_bags: unknown case %r (known: %s)'
                     % (case, ', '.join(sorted(CASES))))
        name, kwargs, seed = CASES[case]
        path = os.path.join(args.out, case + '.bag')
        count = make_bag(path, name, kwargs, seed, args.dur, args.rate,
                         args.noise, store)
        size = os.path.getsize(path)
        print('%s: %d frames of %s %s -> %s (%.0f kB)' % (
            case, count, name, kwargs or '', os.path.relpath(path, ROOT),
            size / 1024.0))
        if size > MAX_BYTES:
            print('make_test_bags: %s is over 2 MB' % path, file=sys.stderr)
            status = 1
    sys.exit(status)


if __name__ == '__main__':
    main()
