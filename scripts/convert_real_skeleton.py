#!/usr/bin/env python3
"""Convert a compact selection of real Kinect skeleton streams into bags.

From ``../shared/data/real_skeleton/`` (its README; MIT licences, see
test/bags/README.md) into test/bags/real_*.bag: one hri_sync/Skeleton
stream on /skeleton each, as the sensor gave it, for the rostests
(skeleton_sensor ~bag replays them at their recorded gaps):

  real_k2_calm    Kinect v2, LabanotationSuite joints.csv 5.2-6.9 s: a
                  person standing between two gestures (the sensor's own
                  jitter, inferred leg joints); the Kinect's timestamps
  real_k2_wave    Kinect v2, Ges01_wavehand.csv whole: waving, with two
                  dropped frames (67 ms gaps) in the Kinect's timestamps
  real_k1_frozen  Kinect v1, PRECOG Seq2_10.csv: the SDK repeating one
                  skeleton for 205 of 206 frames (nominal 30 Hz)
  real_k1_punch   Kinect v1, PRECOG Seq1_10.csv: punching (nominal 30 Hz)

header.stamp = device_stamp = the sensor's timestamp (Kinect v2: its 100 ns
ticks in s; Kinect v1: frame / 30 Hz + 1 s). Confidence: 1 tracked, 0.5
inferred, 0 not tracked. Needs ``rosbags`` (.venv/bin/python).
"""
import argparse
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, 'src'))
sys.path.insert(0, os.path.join(ROOT, 'scripts'))

from hri_sync.people.kinect_csv import (read_kinect_v1,  # noqa: E402
                                        read_kinect_v2)
from make_test_bags import MAX_BYTES, typestore, write_bag  # noqa: E402

DEFAULT_SRC = os.path.join(os.path.dirname(ROOT), 'shared', 'data',
                           'real_skeleton')
# name: (reader, file under the source folder, clip [t0, t1) s or None)
CASES = {
    'real_k2_calm': (read_kinect_v2, 'kinect2_laban/joints.csv', (5.2, 6.9)),
    'real_k2_wave': (read_kinect_v2, 'kinect2_laban/Ges01_wavehand.csv',
                     None),
    'real_k1_frozen': (read_kinect_v1, 'kinect1_precog/Seq2_10.csv', None),
    'real_k1_punch': (read_kinect_v1, 'kinect1_precog/Seq1_10.csv', None),
}


def load(case, src):
    """The Recording of ``case``."""
    reader, name, clip = CASES[case]
    rec = reader(os.path.join(src, name))
    return rec.clip(*clip) if clip else rec


def device_seconds(rec, reader):
    """The frames' device stamps in s (Kinect v2 ticks; v1: index/30+1)."""
    if reader is read_kinect_v2:
        return rec.device_ticks * 1e-7
    return 1.0 + rec.stamps


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--src', default=DEFAULT_SRC)
    parser.add_argument('--out', default=os.path.join(ROOT, 'test', 'bags'))
    parser.add_argument('cases', nargs='*', default=sorted(CASES))
    args = parser.parse_args()
    store = typestore()
    status = 0
    for case in args.cases:
        if case not in CASES:
            sys.exit('convert_real_skeleton: unknown case %r (known: %s)'
                     % (case, ', '.join(sorted(CASES))))
        rec = load(case, args.src)
        path = os.path.join(args.out, case + '.bag')
        write_bag(path, device_seconds(rec, CASES[case][0]), rec.positions,
                  rec.confidence, store, frame_id='kinect')
        size = os.path.getsize(path)
        print('%s: %d frames, %.2f s -> %s (%.0f kB)' % (
            case, len(rec.stamps), rec.stamps[-1],
            os.path.relpath(path, ROOT), size / 1024.0))
        if size > MAX_BYTES:
            print('convert_real_skeleton: %s is over 2 MB' % path,
                  file=sys.stderr)
            status = 1
    sys.exit(status)


if __name__ == '__main__':
    main()
