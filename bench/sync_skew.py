#!/usr/bin/python3
"""Start skew of N skewed clients against the true clock (JSON).

    source <ws>/devel/setup.bash
    /usr/bin/python3 bench/sync_skew.py --clients 2 --rounds 20

Starts, on free ports of its own: a roscore, chronyd (time_server node) as
the global time server, the sensors on the true clock (``signal:
true_time``): one reference for every client (``--sensors shared``,
default) or one per client (``--sensors own``), N clients (CPM + DPM,
``client.launch``) each under one libfaketime clock with a random offset
(+/- --max-offset s) and drift (+/- --max-drift ppm) via ``skewed_client``,
stamping samples at arrival (or by the sensor's device stamp with
``--stamp-source device``), then the server (control and decision modules,
``rounds:=R``).  The bench itself is a ROS node on the true clock: it
records every round and, from the samples each client kept (global stamp
vs the true time written into the sample), each client's clock error and
sample delivery delay, and the start skew (``hri_sync_support.skew_bench``,
``hri_sync_support.skew_figures``).

Progress goes to stderr; the last stdout line is one JSON object.  Every
process it started (and their descendants, each in its own process group)
is stopped on exit, on Ctrl-C and when --timeout runs out.  Exit status 0
when every round produced a full set of OK results, 1 otherwise (the JSON
says what failed), 2 when the setup failed, 130 when interrupted.
"""
import argparse
import os
import random
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__))), 'support'))
from hri_sync_support import skew_bench  # noqa: E402
from hri_sync_support import harness  # noqa: E402


def log(fmt, *args):
    print('sync_skew: ' + (fmt % args if args else fmt), file=sys.stderr,
          flush=True)


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    skew_bench.add_args(p, 20, 'clock offsets within +/- this, s (default 3)')
    skew_bench.add_run_args(p)
    args = p.parse_args()
    skew_bench.check_args(p, args)
    return args


def run(bench, ntp_port):
    """Start everything and record the rounds."""
    args = bench.args
    deadline = time.monotonic() + bench.result['timeout_s']
    rng = random.Random(args.seed)
    master_uri = bench.procs.env['ROS_MASTER_URI']
    bench.start_ros(['roscore', '-p', master_uri.split(':')[-1]], master_uri)
    bench.start_time_server('127.0.0.1', ntp_port)
    log('roscore %s, chronyd on 127.0.0.1:%d', master_uri, ntp_port)
    bench.start_sensors()
    ntp_args = ['ntp_port:=%d' % ntp_port]
    for c in bench.clients:
        bench.clocks[c] = harness.random_clock(rng, args.max_offset,
                                               args.max_drift, time.time())
        log('client %s: faketime %r', c, bench.clocks[c].spec)
        bench.start_client(c, ntp_args)
    bench.wait_clients()
    bench.start_server(ntp_args)
    bench.record_rounds(deadline)


def main():
    args = parse_args()
    started = time.monotonic()
    logdir, env, ntp_port = skew_bench.local_env('hri_sync_bench_')
    procs = harness.Processes(logdir, env, log)
    bench = skew_bench.SkewBench('sync_skew_bench', args, procs, log,
                                 skew_bench.time_budget(args))
    bench.main(lambda: run(bench, ntp_port), procs.stop, logdir, started)


if __name__ == '__main__':
    main()
