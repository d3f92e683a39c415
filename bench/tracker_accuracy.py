#!/usr/bin/python3
"""Accuracy and speed of the depth skeleton tracker on a real motion.

Renders the motion through the virtual Kinect (OpenNI2, in real time), tracks
every frame with the depth backend and compares with the motion's true
joints. The last line printed is one JSON object:
{"mean_error_m", "joints": {name: {"mean_m", "p95_m"}}, "hands_p95_error_m",
 "seen_hands_p95_error_m", "seen_hands_share", "tracked_share", "fps", ...};
"seen_hands" are the hands the tracker gives a confidence of at least 0.5 (the
DPM's threshold; the others are hidden and inferred); fps is frames tracked
per CPU second of the tracker (one core).

    bench/tracker_accuracy.py \
        --motion /work/shared/data/mocap/cmu_60_01_salsa.bvh
    bench/tracker_accuracy.py \
        --motion data/motion/cmu_61_01_salsa.track --res 640x480

Needs the built workspace sourced (source WS/devel/setup.bash).
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, 'src'))


def find_eval():
    try:
        out = subprocess.run(['catkin_find', '--first-only', '--libexec',
                              'hri_sync', 'tracker_eval'],
                             check=True, capture_output=True,
                             text=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        out = ''
    if not out:
        sys.exit(
            'tracker_accuracy: tracker_eval is not built; run make build '
            'and source WS/devel/setup.bash')
    return out


def to_track(motion, tmpdir):
    """A .track file for the motion.

    Converted with hri_sync.dance_off.motion unless it is one.
    """
    if motion.endswith('.track'):
        return os.path.abspath(motion)
    from hri_sync.dance_off.motion import load_motion
    path = os.path.join(
        tmpdir,
        os.path.splitext(
            os.path.basename(motion))[0] +
        '.track')
    load_motion(motion).save_track(
        path, comment='converted by bench/tracker_accuracy.py')
    return path


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--motion', required=True, help='.bvh, .npz or .track')
    ap.add_argument('--res', default='320x240', choices=['320x240', '640x480'])
    ap.add_argument(
        '--seconds',
        type=float,
        default=0.0,
        help='0: the whole motion')
    ap.add_argument(
        '--background',
        action='store_true',
        help='render a back wall and a cabinet')
    ap.add_argument(
        '--noise',
        type=float,
        default=0.0015,
        help='depth noise sigma at 1 m, m')
    ap.add_argument('--direct', action='store_true',
                    help='render in-process, faster than real time '
                         '(skips OpenNI)')
    args = ap.parse_args()
    if not os.path.exists(args.motion):
        sys.exit('tracker_accuracy: no such motion file: %s' % args.motion)
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [find_eval(), '--track', to_track(args.motion, tmp),
               '--res', args.res, '--noise', str(args.noise),
               '--background', '1' if args.background else '0']
        if args.seconds > 0:
            cmd += ['--seconds', str(args.seconds)]
        if args.direct:
            cmd.append('--direct')
        proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        sys.exit(
            'tracker_accuracy: tracker_eval failed: %s' %
            proc.stderr.strip())
    result = json.loads(proc.stdout.strip().splitlines()[-1])
    result['motion'] = os.path.basename(args.motion)
    result['through_openni'] = not args.direct
    print(json.dumps(result))


if __name__ == '__main__':
    main()
