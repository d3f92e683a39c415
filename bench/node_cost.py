#!/usr/bin/python3
"""Benchmark: the CPU a rospy node costs to start and to stop.

Starts a private ROS master (rosmaster) and, NODES times for each mode,
one rospy process that imports rospy, calls init_node, sleeps IDLE s and
shuts down (rospy.signal_shutdown), reading its own CPU time
(getrusage, all threads) after each phase; with ``fixed`` the process
first applies hri_sync.ros.rpc_server.stop_serving_at_shutdown (what every
hri_sync node and checker does), with ``plain`` it does not.  Prints JSON:
per mode, the median and max CPU seconds of each phase and of the whole
process (its rusage as a child), and the ratio of the medians, plain to
fixed.  The spin the fix stops takes what CPU is idle: run it on an idle
machine (beside busy loops the spinning thread gets a small share and the
two modes cost about the same).

    source WS/devel/setup.bash
    bench/node_cost.py [--nodes 10] [--idle 1.0]
"""
import argparse
import json
import os
import resource
import statistics
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__))), 'support'))
from hri_sync_support.harness import (  # noqa: E402
    Processes, free_port, wait_until)

NODE = '''
import json, resource, sys, time
def cpu():
    r = resource.getrusage(resource.RUSAGE_SELF)
    return r.ru_utime + r.ru_stime
c0 = cpu()
import rospy
if sys.argv[1] == 'fixed':   # in the import phase of both modes alike
    from hri_sync.ros.rpc_server import stop_serving_at_shutdown
    stop_serving_at_shutdown()
c1 = cpu()
rospy.init_node('node_cost', anonymous=True)
c2 = cpu()
time.sleep(float(sys.argv[2]))
c3 = cpu()
rospy.signal_shutdown('bench')
c4 = cpu()
print(json.dumps({'import': c1 - c0, 'init': c2 - c1, 'idle': c3 - c2,
                  'shutdown': c4 - c3}))
'''


def one_node(mode, idle, env):
    """The phases' CPU seconds of one node process, and its whole CPU."""
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    out = subprocess.run([sys.executable, '-c', NODE, mode, str(idle)],
                         env=env, capture_output=True, text=True,
                         timeout=120, check=True)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    phases = json.loads(out.stdout.strip().splitlines()[-1])
    phases['process'] = (after.ru_utime - before.ru_utime
                         + after.ru_stime - before.ru_stime)
    return phases


def summary(runs):
    return {k: {'median_s': round(statistics.median(r[k] for r in runs), 3),
                'max_s': round(max(r[k] for r in runs), 3)}
            for k in runs[0]}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--nodes', type=int, default=10)
    parser.add_argument('--idle', type=float, default=1.0)
    args = parser.parse_args()
    port = free_port()
    env = dict(os.environ, ROS_MASTER_URI='http://127.0.0.1:%d' % port)
    with tempfile.TemporaryDirectory(prefix='node_cost_') as logdir:
        procs = Processes(logdir, env)
        try:
            procs.start('master', ['rosmaster', '--core', '-p', str(port)])
            wait_until('the master', lambda: subprocess.run(
                ['rosnode', 'list'], env=env, capture_output=True)
                .returncode == 0, 30.0)
            runs = {m: [] for m in ('plain', 'fixed')}
            for _ in range(args.nodes):     # interleaved: the same load
                for mode in runs:
                    runs[mode].append(one_node(mode, args.idle, env))
        finally:
            procs.stop()
    out = {mode: summary(r) for mode, r in runs.items()}
    out['nodes'] = args.nodes
    out['idle_s'] = args.idle
    out['process_ratio_plain_to_fixed'] = round(
        out['plain']['process']['median_s']
        / out['fixed']['process']['median_s'], 2)
    print(json.dumps(out, indent=1))


if __name__ == '__main__':
    main()
