#!/usr/bin/python3
"""Run ``make test`` several times in a row beside CPU-bound busy loops.

    test_under_load.py [--runs N] [--loops N] [--target T]
                       [--fresh | --checkout DIR]

Starts ``--loops`` busy loops (default: one per core, at normal priority:
plain ``while True: pass`` processes), runs ``make TARGET`` (default
``test``) ``--runs`` times (default 3) one after another in this checkout
(or ``--checkout DIR``, or with ``--fresh`` in a fresh ``git clone`` of its
HEAD in a temporary folder, removed afterwards), and stops the loops
whatever happens (a failed run, Ctrl-C, SIGTERM).  Each run's output goes
to .ws/test_load/run-<k>.log (of the checkout run in; of this one with
--fresh); the failed
tests are read from it (pytest's ``FAILED``, run_rostests.py's ``FAIL``
lines and make's ``*** [...: target] Error`` lines).  The last line printed
is a JSON summary: per run, pass/fail, duration and failed tests.  The exit
status is non-zero when any run failed.
"""
import argparse
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BUSY = 'while True:\n    pass\n'
FAILED_PATTERNS = (
    re.compile(r'^FAILED (\S+)'),                        # pytest -q
    re.compile(r'^FAIL\s+(\S+)'),                        # run_rostests.py
    re.compile(r'^make\[\d+\]: \*\*\* \[\S+: ([\w-]+)\] Error'),  # make
    re.compile(r'^(\w+: FAIL(?: \(|: ).*)$'),    # the stages' own FAIL lines
)


def failed_tests(lines):
    """The failed tests and make targets named in a run's output, in
    order, each once."""
    found = []
    for line in lines:
        for pattern in FAILED_PATTERNS:
            m = pattern.match(line)
            if m and m.group(1) not in found:
                found.append(m.group(1))
    return found


class BusyLoops:
    """Context manager: ``n`` busy-loop processes, each in its own process
    group, stopped (SIGKILL, by pid) on exit."""

    def __init__(self, n):
        self.n = n
        self.procs = []

    def __enter__(self):
        for _ in range(self.n):
            self.procs.append(subprocess.Popen(
                [sys.executable, '-c', BUSY], start_new_session=True,
                stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL))
        return self

    def __exit__(self, *exc):
        for p in self.procs:
            if p.poll() is None:
                p.kill()
            p.wait()
        return False

    @property
    def alive(self):
        return sum(p.poll() is None for p in self.procs)


def fresh_clone(parent):
    """A clone of this checkout's HEAD in ``parent``; its path."""
    path = os.path.join(parent, 'hri_sync')
    subprocess.run(['git', 'clone', '--quiet', ROOT, path], check=True)
    return path


def run_make(checkout, target, log):
    """``make target`` in ``checkout``, its output to ``log``: (exit code,
    duration s, failed tests).  Lines are echoed as they come."""
    t0 = time.monotonic()
    lines = []
    # A top-level make (also under `make test-load`): its own failure line
    # is not a failed test, its sub-makes' are.
    env = {k: v for k, v in os.environ.items()
           if k not in ('MAKELEVEL', 'MAKEFLAGS', 'MFLAGS')}
    with open(log, 'w') as out:
        proc = subprocess.Popen(
            ['make', '--no-print-directory', target], cwd=checkout, env=env,
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
            errors='replace', start_new_session=True)
        try:
            for line in proc.stdout:
                out.write(line)
                lines.append(line.rstrip('\n'))
                sys.stdout.write(line)
                sys.stdout.flush()
            code = proc.wait()
        except BaseException:
            os.killpg(proc.pid, signal.SIGTERM)   # make and its children
            proc.wait()
            raise
    return code, time.monotonic() - t0, failed_tests(lines)


def interrupt(_signum, _frame):
    """SIGTERM ends the runs like Ctrl-C: the loops stop on the way."""
    raise KeyboardInterrupt


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--runs', type=int, default=3)
    parser.add_argument('--loops', type=int,
                        default=len(os.sched_getaffinity(0)),
                        help='busy loops (default: one per usable core)')
    parser.add_argument('--target', default='test', help='make target')
    where = parser.add_mutually_exclusive_group()
    where.add_argument('--fresh', action='store_true',
                       help='run in a fresh clone of HEAD')
    where.add_argument('--checkout', default=ROOT,
                       help='run in this folder (default: this checkout)')
    args = parser.parse_args()
    if args.runs < 1 or args.loops < 0:
        parser.error('--runs must be >= 1 and --loops >= 0')
    signal.signal(signal.SIGTERM, interrupt)
    # Started in the background by a non-interactive shell, this process
    # has SIGINT ignored, and so would every test's process: restore it.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    if signal.getsignal(signal.SIGQUIT) == signal.SIG_IGN:
        signal.signal(signal.SIGQUIT, signal.SIG_DFL)
    tmp = tempfile.mkdtemp(prefix='hri_sync_load_') if args.fresh else None
    summary = {'target': args.target, 'loops': args.loops, 'runs': []}
    try:
        checkout = fresh_clone(tmp) if tmp else args.checkout
        summary['checkout'] = checkout
        logs = os.path.join(ROOT if tmp else checkout, '.ws', 'test_load')
        os.makedirs(logs, exist_ok=True)
        with BusyLoops(args.loops) as loops:
            summary['busy_loop_pids'] = [p.pid for p in loops.procs]
            for k in range(1, args.runs + 1):
                log = os.path.join(logs, 'run-%d.log' % k)
                print('=== run %d/%d: make %s beside %d busy loops (log %s)'
                      % (k, args.runs, args.target, loops.alive, log),
                      flush=True)
                code, duration, failed = run_make(checkout, args.target, log)
                summary['runs'].append({
                    'run': k, 'passed': code == 0,
                    'exit': code, 'duration_s': round(duration, 1),
                    'failed': failed, 'busy_loops_alive': loops.alive,
                    'log': log})
    except KeyboardInterrupt:
        summary['interrupted'] = True
    finally:
        if tmp:
            shutil.rmtree(tmp, ignore_errors=True)
    summary['passed'] = (len(summary['runs']) == args.runs and all(
        r['passed'] for r in summary['runs']))
    print(json.dumps(summary))
    sys.exit(0 if summary['passed'] else 1)


if __name__ == '__main__':
    main()
