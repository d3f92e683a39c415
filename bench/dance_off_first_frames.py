#!/usr/bin/env python3
"""First-frame offsets of two 20 Hz skeleton sensors in one window (JSON).

The paper (section 4, Figure 5) measured how far apart the first frames of
its two Kinects fell in each capture window: 0.017 s on average, against a
frame period of 0.05 s. This runs dance_off.launch --launches times (each
launch starts both sensors with fresh random phases) for --rounds rounds
of --dur s, records each launch to a bag, and from every recorded
ClientResult prints each client's first-frame offset after the window
start and the difference between the two clients. For independent uniform
phases the expected |difference| is a third of the period (16.7 ms at
20 Hz).

Run with the venv's python (it reads the bags with ``rosbags``) in a
sourced workspace: .venv/bin/python bench/dance_off_first_frames.py
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path[:0] = [os.path.join(ROOT, 'src'), os.path.join(ROOT, 'support')]

from hri_sync.dance_off import verify  # noqa: E402
from hri_sync_support.harness import free_port  # noqa: E402


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--launches', type=int, default=6)
    parser.add_argument('--rounds', type=int, default=3)
    parser.add_argument('--dur', type=float, default=2.0)
    args = parser.parse_args()
    folder = tempfile.mkdtemp(prefix='hri_sync_first_frames_')
    rounds = []
    for k in range(args.launches):
        bag = os.path.join(folder, 'launch%d.bag' % k)
        port = free_port()
        env = dict(os.environ, ROS_MASTER_URI='http://localhost:%d' % port)
        subprocess.run(
            ['roslaunch', '-p', str(port), 'hri_sync', 'dance_off.launch',
             'robot:=none', 'music:=false', 'dur:=%g' % args.dur,
             'rounds:=%d' % args.rounds, 'bag:=' + bag,
             'ntp_port:=%d' % free_port()],
            env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
            timeout=120 + args.rounds * (args.dur + 5))
        _, results, _, _, _ = verify.read_bag(bag)
        by_round = {}
        for r in results:
            by_round.setdefault(r.round, {})[r.client_id] = r
        for n, res in sorted(by_round.items()):
            if set(res) != {'left', 'right'}:
                continue
            left = res['left'].first_frame_offset
            right = res['right'].first_frame_offset
            rounds.append({'launch': k, 'round': n,
                           'left_ms': round(left * 1e3, 2),
                           'right_ms': round(right * 1e3, 2),
                           'difference_ms': round(abs(left - right) * 1e3,
                                                  2)})
    diffs = [r['difference_ms'] for r in rounds]
    json.dump({'launches': args.launches, 'rounds_per_launch': args.rounds,
               'rate_hz': 20.0, 'period_ms': 50.0,
               'mean_difference_ms': round(statistics.mean(diffs), 2)
               if diffs else None,
               'max_difference_ms': max(diffs) if diffs else None,
               'paper_mean_difference_ms': 17.0,
               'expected_for_random_phases_ms': round(50.0 / 3, 1),
               'rounds': rounds}, sys.stdout, indent=1)
    print()


if __name__ == '__main__':
    main()
