#!/usr/bin/env python3
"""Benchmark: how long ``report`` takes to render recordings.

Runs ``nodes/report BAG... --out TMP`` ``--runs`` times as a user would
(a fresh process each time: imports, reading, figures, plots, page) and
prints JSON (last line): wall seconds per run (min, median, max), the
rounds rendered, the bags' size and the page's size. The target:
a demo bag (``make demo``) in under 10 s.

    .venv/bin/python bench/report_render.py /tmp/hri_sync_demo_*.bag
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('bags', nargs='+')
    parser.add_argument('--runs', type=int, default=3)
    parser.add_argument('--export', action='store_true',
                        help='also --export csv')
    args = parser.parse_args()
    times = []
    with tempfile.TemporaryDirectory() as out:
        cmd = [sys.executable, os.path.join(ROOT, 'nodes', 'report')] + \
            args.bags + ['--out', out] + (['--export', 'csv']
                                          if args.export else [])
        for _ in range(args.runs):
            start = time.monotonic()
            done = subprocess.run(cmd, stdout=subprocess.DEVNULL,
                                  stderr=subprocess.PIPE, text=True)
            times.append(time.monotonic() - start)
            if done.returncode == 2:
                sys.exit(done.stderr)
        with open(os.path.join(out, 'summary.json')) as f:
            summary = json.load(f)
        page = os.path.getsize(os.path.join(out, 'index.html'))
    print(json.dumps({
        'bags': len(args.bags),
        'bag_bytes': sum(os.path.getsize(b) for b in args.bags),
        'rounds': sum(len(s['rounds']) for s in summary['sessions']),
        'figures': sum(len(s['figures']) for s in summary['sessions']),
        'page_bytes': page, 'runs': args.runs,
        'seconds': {'min': min(times), 'median': statistics.median(times),
                    'max': max(times)},
        'load_average': os.getloadavg()[0]}))


if __name__ == '__main__':
    main()
