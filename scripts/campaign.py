#!/usr/bin/python3
"""The paper's 35-round check, automated: run, record, verify, report.

The paper's authors ran 35 pair tests and checked each decision by reading
logs. This runs a session of ``--pairs`` x ``--rounds`` rounds (default
7 x 5 = 35) of ``dance_off.launch`` with DJ Rob (simulated) and the music,
each pair a launch recorded to its own bag: participants drawn (seeded)
from the motion clips in data/motion as a dancer (the clip at full
speed), a person making small movements (the clip at 0.3x) or a still
person (the clip frozen), the pair kinds covering dancer/still,
small/still, dancer/small, still/still, dancer/dancer, sides alternating
from pair to pair, every other pair's clients under libfaketime clocks
(+1.2 s at +200 ppm, -0.8 s at -200 ppm), a short DUR. Then it runs
``verify_decisions`` and ``report`` on all the bags and prints one line:
rounds, decisions reproduced, robot gestures correct, start skew p99,
error bound p99 (and how many decisions named the participant who moved
more, where the kinds differ). Exit status 0 only if every round passed.

    source .ws/devel/setup.bash
    /usr/bin/python3 scripts/campaign.py [--out DIR] [--seed 1] [--dur 3]

(``--verify-only`` re-runs verify_decisions and report on the bags of an
earlier run in --out.)
"""
import argparse
import glob
import json
import os
import random
import subprocess
import sys
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path[:0] = [os.path.join(ROOT, 'src'), os.path.join(ROOT, 'support')]
from hri_sync.clock.skew import percentiles  # noqa: E402
from hri_sync_support.harness import free_port  # noqa: E402

KINDS = [('dancer', 'still'), ('small', 'still'), ('dancer', 'small'),
         ('still', 'still'), ('dancer', 'dancer'), ('small', 'still'),
         ('dancer', 'still')]
RANK = {'still': 0, 'small': 1, 'dancer': 2}
CLOCKS = ('+1.2s x1.0002', '-0.8s x0.9998')



def participant(side, kind, clip, rng):
    """Launch args of one side."""
    args = ['%s_motion:=%s' % (side, clip),
            '%s_seed:=%d' % (side, rng.randrange(1, 10 ** 6))]
    if kind == 'still':
        args.append('%s_hold:=%.2f' % (side, rng.uniform(0.0, 5.0)))
    else:
        args.append('%s_offset:=%.2f' % (side, rng.uniform(0.0, 5.0)))
    if kind == 'small':
        args.append('%s_speed:=0.3' % side)
    return args


def plan(pairs, seed):
    """[(left kind, right kind, launch args)] of the campaign."""
    rng = random.Random(seed)
    clips = sorted(os.path.basename(p)[:-4] for p in
                   glob.glob(os.path.join(ROOT, 'data', 'motion', '*.npz')))
    out = []
    for k in range(pairs):
        kinds = KINDS[k % len(KINDS)]
        if k % 2:
            kinds = kinds[::-1]             # sides alternate
        left, right = rng.sample(clips, 2)
        args = participant('left', kinds[0], left, rng) + \
            participant('right', kinds[1], right, rng)
        if k % 2:
            args += ['left_clock:=' + CLOCKS[0], 'right_clock:=' + CLOCKS[1]]
        out.append((kinds, args))
    return out


def run_pair(k, kinds, args, rounds, dur, out):
    bag = os.path.join(out, 'pair%02d.bag' % (k + 1))
    port = free_port()
    cmd = ['roslaunch', '-p', str(port), 'hri_sync', 'dance_off.launch',
           'rounds:=%d' % rounds, 'dur:=%g' % dur, 'bag:=' + bag,
           'ntp_port:=%d' % free_port()] + args
    print('pair %d (%s left, %s right): %s' % (k + 1, kinds[0], kinds[1],
                                               ' '.join(args)), flush=True)
    log = bag[:-len('.bag')] + '.log'
    env = dict(os.environ, ROS_MASTER_URI='http://localhost:%d' % port)
    start = time.time()
    with open(log, 'w') as f:
        done = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT,
                              env=env, timeout=120 + rounds * (dur + 30))
    print('  %.0f s, exit %d, %s' % (time.time() - start, done.returncode,
                                     bag if os.path.exists(bag) else
                                     'NO BAG (see %s)' % log), flush=True)
    return bag, kinds


def expected(kinds, decision):
    """None if the kinds are alike (any decision), else whether the
    decision names the side that moved more (both still: no_winner)."""
    if kinds == ('still', 'still'):
        return decision['outcome'] == 'no_winner'
    if kinds[0] == kinds[1]:
        return None
    want = 1 if RANK[kinds[0]] > RANK[kinds[1]] else 2
    return decision['outcome'] == 'winner' and decision['winner'] == want


def p99(d):
    v = d['p99']
    return 'n/a' if v != v else '%.3f ms' % v


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--out', default='/tmp/hri_sync_campaign_%s'
                        % time.strftime('%Y%m%d_%H%M%S'))
    parser.add_argument('--pairs', type=int, default=7)
    parser.add_argument('--rounds', type=int, default=5,
                        help='rounds per pair (default 5: 35 in all)')
    parser.add_argument('--dur', type=float, default=3.0)
    parser.add_argument('--seed', type=int, default=1)
    parser.add_argument('--verify-only', action='store_true',
                        help='verify and report the bags already in --out '
                        '(recorded with the same --pairs and --seed)')
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    pairs = plan(args.pairs, args.seed)
    if args.verify_only:
        bags = [(os.path.join(args.out, 'pair%02d.bag' % (k + 1)), kinds)
                for k, (kinds, _) in enumerate(pairs)]
    else:
        bags = [run_pair(k, kinds, launch_args, args.rounds, args.dur,
                         args.out)
                for k, (kinds, launch_args) in enumerate(pairs)]
    recorded = [b for b, _ in bags if os.path.exists(b)]
    if not recorded:
        sys.exit('campaign: no bag was recorded (logs in %s)' % args.out)
    nodes = os.path.join(ROOT, 'nodes')
    with open(os.path.join(args.out, 'verify.txt'), 'w') as f:
        verify = subprocess.run(['/usr/bin/python3', os.path.join(
            nodes, 'verify_decisions')] + recorded, stdout=f,
            stderr=subprocess.STDOUT)
    report_dir = os.path.join(args.out, 'report')
    with open(os.path.join(args.out, 'report.txt'), 'w') as f:
        rep = subprocess.run(['/usr/bin/python3', os.path.join(
            nodes, 'report')] + recorded + ['--out', report_dir],
            stdout=f, stderr=subprocess.STDOUT)
    summary_path = os.path.join(report_dir, 'summary.json')
    if not os.path.exists(summary_path):
        sys.exit('campaign: report failed (see %s/report.txt)' % args.out)
    with open(summary_path) as f:
        summary = json.load(f)
    kinds = {b: k for b, k in bags}
    rounds, matched, judged = [], 0, 0
    for s in summary['sessions']:
        for r in s['rounds']:
            rounds.append(r)
            if r.get('decision'):
                ok = expected(kinds[s['bag']], r['decision'])
                judged += ok is not None
                matched += bool(ok)
    decided = [r for r in rounds if not r['cut_off']]
    reproduced = sum(bool(r['recomputed']['reproduced']) for r in decided)
    robot = [r['robot']['ok'] for r in decided if 'robot' in r]
    skews = percentiles([r['start_skew_ms'] for r in rounds
                         if r['start_skew_ms'] is not None])
    bounds = percentiles([r['error_bound_ms'] for r in rounds
                          if r['error_bound_ms'] is not None])
    outcomes = {}
    for r in decided:
        outcomes[r['decision']['outcome']] = \
            outcomes.get(r['decision']['outcome'], 0) + 1
    ok = verify.returncode == 0 and rep.returncode == 0 and \
        len(decided) == args.pairs * args.rounds
    print('campaign: %d rounds (%s), %d/%d decisions reproduced, robot '
          'gestures correct %d/%d, start skew p99 %s, error bound p99 %s; '
          'the one who moved more won %d/%d; verify_decisions %s; %s'
          % (len(rounds), ', '.join('%s %d' % kv for kv in
                                    sorted(outcomes.items())),
             reproduced, len(decided), sum(x is True for x in robot),
             len(robot), p99(skews), p99(bounds), matched,
             judged, 'pass' if verify.returncode == 0 else
             'FAIL (exit %d)' % verify.returncode,
             os.path.join(report_dir, 'index.html')))
    sys.exit(0 if ok else 1)


if __name__ == '__main__':
    main()
