#!/usr/bin/env python3
"""Convert BVH motion capture into the compact motion files of data/motion/.

For each BVH file: ``<name>.npz`` (times, 15-joint positions in the sensor
frame to 0.1 mm, orientations; resampled to --rate Hz, compressed) and, for
the clips named by --track (or all with --track all), the plain-text
``<name>.track`` the C++ virtual Kinect reads. See
hri_sync.dance_off.motion for the sensor frame and the 1.70 m height scaling.

    scripts/convert_mocap.py                     # ../shared/data/mocap
    scripts/convert_mocap.py --src DIR --out data/motion my_dance.bvh
"""
import argparse
import glob
import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, 'src'))

from hri_sync.dance_off.bvh import BvhError  # noqa: E402
from hri_sync.dance_off.motion import load_motion  # noqa: E402

DEFAULT_SRC = os.path.join(os.path.dirname(ROOT), 'shared', 'data', 'mocap')
DEFAULT_TRACKS = ('cmu_60_01_salsa,cmu_61_01_salsa,cmu_131_01_walk,'
                  'cmu_60_07_salsa')
MAX_BYTES = 2 * 1024 * 1024
ACK = ('Motion data from mocap.cs.cmu.edu (CMU Graphics Lab Motion Capture '
       'Database, funded by NSF EIA-0196217).')


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('files', nargs='*',
                        help='BVH files (default: every *.bvh in --src)')
    parser.add_argument('--src', default=DEFAULT_SRC,
                        help='folder of BVH files (default %(default)s)')
    parser.add_argument('--out', default=os.path.join(ROOT, 'data', 'motion'))
    parser.add_argument('--rate', type=float, default=60.0,
                        help='output rate, Hz (default %(default)s)')
    parser.add_argument('--track', default=DEFAULT_TRACKS,
                        help="clips to write as .track too: comma list, "
                             "'all' or '' (default %(default)s)")
    args = parser.parse_args()
    files = args.files or sorted(glob.glob(os.path.join(args.src, '*.bvh')))
    if not files:
        sys.exit('convert_mocap: no BVH files in %s (pass --src or files)'
                 % args.src)
    tracks = set(t for t in args.track.split(',') if t)
    os.makedirs(args.out, exist_ok=True)
    failed = 0
    for path in files:
        name = os.path.splitext(os.path.basename(path))[0]
        try:
            motion = load_motion(path).resample(args.rate)
        except BvhError as exc:
            print('convert_mocap: %s' % exc, file=sys.stderr)
            failed += 1
            continue
        outputs = [os.path.join(args.out, name + '.npz')]
        motion.save_npz(outputs[0])
        if 'all' in tracks or name in tracks:
            outputs.append(os.path.join(args.out, name + '.track'))
            motion.save_track(outputs[1], comment='source: %s\n%s'
                              % (os.path.basename(path), ACK))
        for out in outputs:
            size = os.path.getsize(out)
            print('%s: %d frames @ %.0f Hz, %.1f s -> %s (%.0f kB)'
                  % (name, len(motion.times), args.rate, motion.duration,
                     os.path.relpath(out, ROOT), size / 1024.0))
            if size > MAX_BYTES:
                print('convert_mocap: %s is over 2 MB: lower --rate' % out,
                      file=sys.stderr)
                failed += 1
    sys.exit(1 if failed else 0)


if __name__ == '__main__':
    main()
