#!/usr/bin/python3
"""Benchmark: several simulated robots dancing in unison.

For each N of --robots, runs --rounds rounds (time server, server, one
participant on a synthetic sensor, N robots from robots.launch: robot1..N
on kobuki_sim, each in its own namespace under its own libfaketime clock)
on a private ROS master, and prints JSON per N:
- start skew across the robots in true time (per round: the spread of
  the robots' raw CLOCK_REALTIME readings at their first dance command;
  the time server serves this host's clock, so global = true): p50, p99,
  max over the rounds;
- each robot's start offset from CR_T+STR_AFT in true time (all robots
  and rounds pooled);
- heading agreement over the dances: the largest difference between two
  robots' odometry headings (each robot's odometry stamps put on the
  global clock by its own clock model) every 20 ms of every window:
  p50, p99, max in degrees.
The participant never wins (min_expressiveness is out of reach), so the
robots dance and do not gesture, and rounds follow each other closely.

    source WS/devel/setup.bash
    bench/robots_unison.py --robots 2 4 --rounds 20 --dur 6
"""
import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__))), 'support'))
from hri_sync_support.harness import (  # noqa: E402
    add_start_args, one_client_launch, run_private_launch)

CLOCKS = '+1.7s x1.0002;-2.3s x0.9997;+0.6s x1.00015;-0.9s x0.99985'
ROBOTS = """  <include file="$(find hri_sync)/launch/robots.launch">
    <arg name="n" value="{n}"/>
    <arg name="clocks" value="{clocks}"/>
    <arg name="ntp_port" value="$(arg ntp_port)"/>
    <arg name="start_spin" value="{spin}"/>
    <arg name="realtime_priority" value="{rt}"/>
  </include>"""


def run(n, opts):
    """One launch of ``n`` robots for ``opts.rounds`` rounds: its JSON."""
    ids = ','.join('robot%d' % (i + 1) for i in range(n))
    path = os.path.join(tempfile.mkdtemp(prefix='robots_unison_'),
                        'bench.launch')
    with open(path, 'w') as f:
        f.write(one_client_launch(ids, opts.rounds, opts.dur, ROBOTS.format(
            n=n, clocks=opts.clocks, spin=opts.spin,
            rt=opts.realtime_priority), round_pause=1.0,
            min_expressiveness='1e9'))
    load = os.getloadavg()[0]
    with open(path + '.log', 'w') as log:
        result = run_private_launch(
            path, lambda _proc: observe(ids.split(','), opts),
            stop_wait=30.0, log=log)
    result.update(robots=n, load_average_1min=[load, os.getloadavg()[0]],
                  log=log.name)
    return result


def observe(robots, opts):
    """Watch the rounds of one launch: the figures of one N."""
    import rosgraph
    import rospy
    from hri_sync.ros.unison_watch import RobotsWatch
    from hri_sync.tools.unison import distribution
    deadline = time.time() + 30.0
    while not rosgraph.is_master_online() and time.time() < deadline:
        time.sleep(0.2)
    rospy.init_node('robots_unison_bench', disable_signals=True)
    watch = RobotsWatch(robots)
    deadline = time.time() + 90 + opts.rounds * (opts.dur + 8)
    while time.time() < deadline and len(watch.decisions) < opts.rounds:
        time.sleep(0.2)
    time.sleep(1.0)
    skews, missing = watch.skews()
    starts = watch.start_times()
    offsets = [t - watch.captures[n].start for n, by_robot in starts.items()
               if n in watch.captures for t in by_robot.values()]
    tracks = watch.sorted_tracks()
    spreads = [math.degrees(s) for n in sorted(watch.captures)
               for s in watch.dance_spreads(n, tracks)]
    rospy.signal_shutdown('bench done')
    return {
        'rounds_requested': opts.rounds,
        'rounds_started': len(watch.captures),
        'rounds_decided': len(watch.decisions),
        'outcomes': sorted({(d.outcome, d.reason[:120]) for d in
                            watch.decisions.values()}),
        'rounds_missing_a_robot': {str(k): v for k, v in missing.items()},
        'start_skew_true': distribution(list(skews.values()), 1e3),
        'start_offset_true': distribution(offsets, 1e3),
        'start_abs_offset_true': distribution([abs(v) for v in offsets],
                                              1e3),
        'heading_spread_over_dances': distribution(spreads, unit='deg'),
        'per_round_skew_ms': {str(k): round(v * 1e3, 4)
                              for k, v in sorted(skews.items())},
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--robots', type=int, nargs='+', default=[2, 4])
    ap.add_argument('--rounds', type=int, default=20)
    ap.add_argument('--dur', type=float, default=6.0)
    ap.add_argument('--clocks', default=CLOCKS,
                    help="faketime specs, ';'-separated, one per robot in "
                    "turn; none: the host clock")
    add_start_args(ap, 'the robots')
    ap.add_argument('--one', type=int, default=0, help=argparse.SUPPRESS)
    opts = ap.parse_args()
    if opts.one:        # one N in a process of its own (one rospy node)
        print(json.dumps(run(opts.one, opts)))
        return 0
    results = []
    for n in opts.robots:
        out = subprocess.run(
            [sys.executable, os.path.abspath(__file__), '--one', str(n),
             '--rounds', str(opts.rounds), '--dur', str(opts.dur),
             '--clocks', opts.clocks, '--spin', str(opts.spin),
             '--realtime-priority', str(opts.realtime_priority)],
            stdout=subprocess.PIPE, text=True, check=True).stdout
        results.append(json.loads(out.strip().splitlines()[-1]))
    print(json.dumps({'benchmark': 'robots_unison', 'dur_s': opts.dur,
                      'clocks': opts.clocks, 'start_spin_s': opts.spin,
                      'realtime_priority': opts.realtime_priority,
                      'runs': results}, indent=1))


if __name__ == '__main__':
    sys.exit(main())
