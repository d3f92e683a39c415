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
    bench/tracker_accuracy.py --motion data/motion/cmu_60_01_salsa.track \
        --scene 'body=tall_slim&wall=0.3&noise=kinect1'

--matrix runs the accuracy table: body shapes x scenes (empty: floor only;
wall + floor; bystander: a second person walking behind) x noise (none;
Kinect v1), rendered in-process (--direct; the driver renders the same frames,
test/unit/virtual_kinect_gtest.cpp), and prints one JSON object with every
cell and whether it meets the targets (mean <= 0.10 m and hands p95 <= 0.25 m
without a bystander; tracked >= 90 % after calibration; >= 30 frames per CPU
second at 320x240); --markdown FILE also writes the table.

Needs the built workspace sourced (source WS/devel/setup.bash).
"""
import argparse
import concurrent.futures
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


def still_track(track, tmpdir, seconds=10.0):
    """A .track of a person standing still in the motion's first pose."""
    with open(track) as f:
        first = next(line for line in f
                     if line.strip() and not line.startswith('#'))
    pose = first.split()[1:]
    path = os.path.join(tmpdir, 'still.track')
    with open(path, 'w') as f:
        f.write('# the first pose of %s, still\n' % os.path.basename(track))
        for t in (0.0, seconds):
            f.write('%g %s\n' % (t, ' '.join(pose)))
    return path


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


MATRIX_BODIES = ('average', 'short_broad', 'tall_slim', 'loose_clothes')
MATRIX_SCENES = (('empty', ''), ('wall_floor', 'wall=0.3'),
                 ('bystander', 'bystander=walk&bystander_offset=0.7'))
MATRIX_NOISE = (('none', ''), ('kinect1', 'noise=kinect1'))
WALK = os.path.join(ROOT, 'data', 'motion', 'cmu_131_01_walk.track')
TARGETS = {'mean_error_m': 0.10, 'hands_p95_error_m': 0.25,
           'tracked_share_after_calibration': 0.90, 'fps': 30.0}


def run_eval(exe, track, res, seconds, direct, scene='', noise=None,
             background=False, users=0):
    """One tracker_eval run; its JSON result (SystemExit on failure).
    users: 0 the single-user tracker, 1-4 the node's multi-user tracker."""
    cmd = [exe, '--track', track, '--res', res,
           '--background', '1' if background else '0', '--users', str(users)]
    if noise is not None:
        cmd += ['--noise', str(noise)]
    if scene:
        cmd += ['--scene', scene]
    if seconds > 0:
        cmd += ['--seconds', str(seconds)]
    if direct:
        cmd.append('--direct')
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        sys.exit('tracker_accuracy: tracker_eval failed: %s' %
                 proc.stderr.strip())
    return json.loads(proc.stdout.strip().splitlines()[-1])


def judge(cell):
    """The targets a cell meets (None: the target does not apply).

    A cell never tracked has no error (tracker_eval reports -1): its error
    targets are not met.
    """
    no_bystander = cell['scene'] != 'bystander'
    seen = cell['tracked_share_after_calibration'] > 0

    def error_met(key):
        if not no_bystander:
            return None
        return seen and 0 <= cell[key] <= TARGETS[key]
    return {
        'mean_error': error_met('mean_error_m'),
        'hands_p95': error_met('hands_p95_error_m'),
        'tracked': (cell['tracked_share_after_calibration'] >=
                    TARGETS['tracked_share_after_calibration']),
        'fps': (cell['fps'] >= TARGETS['fps']
                if cell['resolution'] == '320x240' else None),
    }


def matrix(exe, track, args):
    """Every cell of bodies x scenes x noise."""
    jobs = []
    for body in args.bodies.split(','):
        for scene, skeys in MATRIX_SCENES:
            for noise, nkeys in MATRIX_NOISE:
                keys = '&'.join(k for k in ('body=' + body, skeys, nkeys)
                                if k)
                if scene == 'bystander':
                    keys += '&bystander_track=' + WALK
                jobs.append((body, scene, noise, keys))
    cells = []
    with concurrent.futures.ThreadPoolExecutor(args.jobs) as pool:
        futures = [pool.submit(run_eval, exe, track, args.res, args.seconds,
                               True, keys, None, False, args.users)
                   for _, _, _, keys in jobs]
        for (body, scene, noise, keys), fut in zip(jobs, futures):
            r = fut.result()
            cell = {'body': body, 'body_height_m': r['body_height_m'],
                    'scene': scene, 'noise': noise, 'keys': keys}
            for k in ('mean_error_m', 'hands_p95_error_m',
                      'seen_hands_p95_error_m', 'tracked_share',
                      'tracked_share_after_calibration',
                      'first_tracked_frame', 'fps', 'frames', 'resolution',
                      'mean_tracked_users'):
                cell[k] = r[k]
            cell['met'] = judge(cell)
            print(json.dumps(cell), file=sys.stderr, flush=True)
            cells.append(cell)
    return cells


def markdown(result):
    """The table for docs/tracker.md."""
    mark = {True: 'yes', False: '**no**', None: 'n/a'}
    lines = ['| body (height) | scene | noise | mean (m) | hands p95 (m) | '
             'tracked after calib. | frames / CPU s | targets met |',
             '|---|---|---|---|---|---|---|---|']
    def error(value):
        return '%.3f' % value if value >= 0 else 'none (never tracked)'
    for c in result['cells']:
        met = judge(c)
        body = ('%s (capsule fit model)' % c['body'] if c['body'] == 'model'
                else '%s (%.2f m)' % (c['body'], c['body_height_m']))
        lines.append(
            '| %s | %s | %s | %s | %s | %.1f %% | %.0f | '
            'mean %s, hands %s, tracked %s, speed %s |' % (
                body, c['scene'], c['noise'],
                error(c['mean_error_m']), error(c['hands_p95_error_m']),
                100 * c['tracked_share_after_calibration'], c['fps'],
                mark[met['mean_error']], mark[met['hands_p95']],
                mark[met['tracked']], mark[met['fps']]))
    return '\n'.join(lines) + '\n'


def git_commit():
    try:
        return subprocess.run(['git', '-C', ROOT, 'describe', '--always',
                               '--dirty'], capture_output=True, text=True,
                              check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return ''


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--motion', default='', help='.bvh, .npz or .track')
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
    ap.add_argument('--scene', default='',
                    help="virtual Kinect scene keys, e.g. "
                         "'body=tall_slim&wall=0.3&noise=kinect1' "
                         "(docs/tracker.md); --noise is then unused")
    ap.add_argument('--matrix', action='store_true',
                    help='the accuracy table: bodies x scenes x noise')
    ap.add_argument('--bodies', default=','.join(MATRIX_BODIES),
                    help='--matrix body shapes, comma-separated')
    ap.add_argument('--jobs', type=int, default=1,
                    help='--matrix cells run at once')
    ap.add_argument('--markdown', help='--matrix: also write the table here')
    ap.add_argument('--users', type=int, default=0,
                    help='0: the single-user tracker; 1-4: the multi-user '
                         'tracker the node runs (scored on the user nearest '
                         'the person)')
    ap.add_argument('--table', metavar='RESULT.json',
                    help='print the markdown table of a saved --matrix '
                         'result and exit')
    ap.add_argument('--still', action='store_true',
                    help="a still person in the motion's first pose, 10 s")
    args = ap.parse_args()
    if args.table:
        with open(args.table) as f:
            sys.stdout.write(markdown(json.load(f)))
        return
    if not args.motion or not os.path.exists(args.motion):
        sys.exit('tracker_accuracy: no such motion file: %s' % args.motion)
    exe = find_eval()
    with tempfile.TemporaryDirectory() as tmp:
        track = to_track(args.motion, tmp)
        if args.still:
            track = still_track(track, tmp)
        if args.matrix:
            commit = git_commit()  # before the run: the code measured
            result = {'motion': os.path.basename(args.motion),
                      'still': args.still, 'users': args.users,
                      'commit': commit, 'targets': TARGETS,
                      'through_openni': False,
                      'cells': matrix(exe, track, args)}
            if args.markdown:
                with open(args.markdown, 'w') as out:
                    out.write(markdown(result))
        else:
            result = run_eval(exe, track, args.res, args.seconds,
                              args.direct, args.scene,
                              None if args.scene else args.noise,
                              args.background, args.users)
            result['motion'] = os.path.basename(args.motion)
            result['still'] = args.still
            result['through_openni'] = not args.direct
    print(json.dumps(result))


if __name__ == '__main__':
    main()
