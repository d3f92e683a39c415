#!/usr/bin/python3
"""hri_sync's clock agreement against LSL's, side by side in one run (JSON).

    source <ws>/devel/setup.bash
    /usr/bin/python3 bench/lsl_compare.py --clients 4 --rounds 20 --seed 1

The skew bench of bench/sync_skew.py (a roscore, chronyd as the time
server, N clients each under a libfaketime clock of random offset, +/-
--max-offset s, and drift, +/- --max-drift ppm, and the server) and, on
each client's clock (the same faketime spec), an LSL outlet whose samples
carry their true time (``hri_sync_support.lsl_bench``).  The bench process,
on the true clock, records the rounds and is the lab's LSL recorder: it
maps each client's LSL stamps with time_correction() as LSL's docs show
it, with a drift fit over the run's estimates (as LSL's docs suggest for
XDF files), and with hri_sync's live fit (nodes/lsl_inlet).  The truth is
the raw-syscall CLOCK_MONOTONIC (libfaketime does not see it) each sample
carries.

Agreement is the spread over the clients of their clock errors at each
round's window start (``clock_skew_ms``: hri_sync's clock models, LSL's
mappings); errors are per client.  Progress on stderr; the last stdout
line is one JSON object; exit status as bench/sync_skew.py's.
"""
import argparse
import os
import random
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), 'support'))
from hri_sync.tools import venv  # noqa: E402

venv.ensure(['pylsl'], 'lsl_compare', __file__)

import rospy  # noqa: E402

from hri_sync.msg import CaptureData  # noqa: E402
from hri_sync_support import harness, lsl_bench, skew_bench  # noqa: E402

LSL_RATE = 20.0   # Hz of each client's LSL outlet


def log(fmt, *args):
    print('lsl_compare: ' + (fmt % args if args else fmt), file=sys.stderr,
          flush=True)


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    skew_bench.add_args(p, 20, 'clock offsets within +/- this, s (default 3)')
    skew_bench.add_run_args(p)
    # The LSL recorder connects before the warm-up, as LabRecorder runs
    # before a session: the live fit has its first estimates by round 1.
    p.set_defaults(clients=4, warmup=6.0)
    args = p.parse_args()
    skew_bench.check_args(p, args)
    return args


class Run:
    """The skew bench plus an LSL outlet per client and the recorder."""

    def __init__(self, bench, ntp_port):
        self.bench = bench
        self.ntp_port = ntp_port
        self.recorder = lsl_bench.LslRecorder(log)
        self.starts = {}
        self.since = None
        self.offset = None

    def start_lsl(self, client):
        clock = self.bench.clocks[client]
        argv = [sys.executable, '-m', 'hri_sync_support.lsl_bench', 'source',
                'lsl_bench_' + client, str(LSL_RATE)]
        if (clock.offset, clock.rate) != (0.0, 1.0):
            argv = ['faketime', '-f', clock.spec] + argv
        self.bench.started.append(('lsl_' + client, self.bench.procs.start(
            'lsl_' + client, argv)))

    def on_capture(self, msg):
        self.starts[msg.round] = msg.header.stamp.to_sec() + msg.str_aft

    def __call__(self):
        bench, args = self.bench, self.bench.args
        deadline = time.monotonic() + bench.result['timeout_s']
        rng = random.Random(args.seed)
        master_uri = bench.procs.env['ROS_MASTER_URI']
        bench.start_ros(['roscore', '-p', master_uri.split(':')[-1]],
                        master_uri)
        bench.start_time_server('127.0.0.1', self.ntp_port)
        bench.start_sensors()
        ntp_args = ['ntp_port:=%d' % self.ntp_port]
        for c in bench.clients:
            bench.clocks[c] = harness.random_clock(
                rng, args.max_offset, args.max_drift, time.time())
            log('client %s: faketime %r', c, bench.clocks[c].spec)
            bench.start_client(c, ntp_args)
            self.start_lsl(c)
        rospy.Subscriber('/capture_data', CaptureData, self.on_capture)
        bench.wait_clients()
        self.recorder.connect({c: 'lsl_bench_' + c for c in bench.clients})
        log('LSL recorder connected to %d outlets', len(bench.clients))
        self.since = time.time() + args.warmup
        bench.start_server(ntp_args)
        bench.record_rounds(deadline)
        self.offset = self.recorder.stop()

    def figures(self):
        """The 'lsl' key of the JSON."""
        if self.offset is None:
            return {'lsl': {'error': 'the run did not reach the rounds'}}
        starts = [t for n, t in sorted(self.starts.items())]
        return {'lsl': lsl_bench.figures(self.recorder, self.offset,
                                         self.since, starts),
                'lsl_rate_hz': LSL_RATE}


def main():
    args = parse_args()
    started = time.monotonic()
    logdir, env, ntp_port = skew_bench.local_env(
        'hri_sync_lsl_compare_',
        [os.path.join(os.path.dirname(HERE), 'support')] + sys.path[1:])
    procs = harness.Processes(logdir, env, log)
    bench = skew_bench.SkewBench('lsl_compare_bench', args, procs, log,
                                 skew_bench.time_budget(args) + 60.0)
    run = Run(bench, ntp_port)
    bench.main(run, procs.stop, logdir, started, more=run.figures)


if __name__ == '__main__':
    main()
