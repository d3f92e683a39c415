#!/usr/bin/python3
"""Benchmark: how close to the scheduled start DJ Rob dances, music plays.

Runs ROUNDS back-to-back rounds (time server, server, one sensor client,
DJ Rob on kobuki_sim, the music) on a private ROS master, each of the robot
and the music optionally under its own libfaketime clock, and prints JSON:
per action, the start offset from CR_T+STR_AFT in true time (the node's
raw host-clock reading at the start; the time server serves this host's
clock, so global = true) and, for the robot, the arrival of its first
command at an outside subscriber (includes ROS transport; the observer
runs SCHED_FIFO when permitted).

    source WS/devel/setup.bash
    bench/dj_rob_start.py --rounds 10 --dur 3 [--robot-clock '+2.5s x1.0002']
"""
import argparse
import json
import math
import os
import sys
import tempfile
import threading
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__))), 'support'))
from hri_sync_support.harness import (  # noqa: E402
    add_start_args, one_client_launch, percentiles_ms as stats,
    run_private_launch)

HERE = os.path.dirname(os.path.abspath(__file__))

INCLUDE = """<include file="$(find hri_sync)/launch/dj_rob.launch">
    <arg name="robot" value="{robot}"/>
    <arg name="music" value="{music}"/>
    <arg name="ntp_port" value="$(arg ntp_port)"/>
    <arg name="start_spin" value="{spin}"/>
    <arg name="realtime_priority" value="{rt}"/>
  </include>"""
SKEWED = """<node pkg="hri_sync" type="skewed_client" name="{name}_clock"
        args="--clock '{clock}' dj_rob.launch robot:={robot} music:={music}
              ntp_port:=$(arg ntp_port) start_spin:={spin}
              realtime_priority:={rt}"/>"""



def part(name, clock, robot, music, opts):
    if clock:
        return SKEWED.format(name=name, clock=clock, robot=robot,
                             music=music, spin=opts.spin,
                             rt=opts.realtime_priority)
    return INCLUDE.format(robot=robot, music=music, spin=opts.spin,
                          rt=opts.realtime_priority)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--rounds', type=int, default=10)
    ap.add_argument('--dur', type=float, default=3.0)
    ap.add_argument('--robot-clock', default='')
    ap.add_argument('--music-clock', default='')
    add_start_args(ap, 'both nodes')
    opts = ap.parse_args()
    launch = one_client_launch(
        'dj_rob,music', opts.rounds, opts.dur,
        part('robot', opts.robot_clock, 'sim', 'false', opts) + '\n  ' +
        part('music', opts.music_clock, 'none', 'true', opts))
    workdir = tempfile.mkdtemp(prefix='dj_rob_bench_')
    path = os.path.join(workdir, 'bench.launch')
    with open(path, 'w') as f:
        f.write(launch)
    result = run_private_launch(path, lambda proc: observe(opts))
    print(json.dumps(result, indent=1))


def observe(opts):
    import rosgraph
    import rospy
    from geometry_msgs.msg import Twist
    from hri_sync.clock.truth import realtime
    from hri_sync.msg import ActionStart, CaptureData, Decision
    from hri_sync.wire.protocol import Capture
    deadline = time.time() + 30.0
    while not rosgraph.is_master_online() and time.time() < deadline:
        time.sleep(0.2)
    # Observe arrivals promptly on a busy machine (rospy's threads inherit
    # this policy), below the nodes' own priority.
    with realtime(5) as rt:
        pass
    if rt.ok:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(5))
    rospy.init_node('dj_rob_bench', disable_signals=True)
    lock = threading.Lock()
    captures, starts, first_cmd, decisions = {}, {}, {}, set()

    def on_capture(m):
        with lock:
            captures[m.round] = Capture.from_msg(m).start

    def on_start(m):
        with lock:
            starts[(m.round, m.action)] = m.true_time.to_sec()

    def on_cmd(_m):
        t = time.time()
        with lock:
            for r, start in captures.items():
                if r not in first_cmd and t > start - 1.0:
                    first_cmd[r] = t

    rospy.Subscriber('/capture_data', CaptureData, on_capture)
    for topic in ('/dj_rob/action_start', '/music/action_start'):
        rospy.Subscriber(topic, ActionStart, on_start)
    rospy.Subscriber('/mobile_base/commands/velocity', Twist, on_cmd,
                     tcp_nodelay=True)
    rospy.Subscriber('/decision', Decision,
                     lambda m: decisions.add(m.round))
    deadline = time.time() + 60 + opts.rounds * (opts.dur + 5)
    while time.time() < deadline and len(decisions) < opts.rounds:
        time.sleep(0.2)
    time.sleep(1.0)
    with lock:
        rounds = sorted(captures)
        dance = [starts.get((r, 'dance'), math.nan) - captures[r]
                 for r in rounds]
        music = [starts.get((r, 'music'), math.nan) - captures[r]
                 for r in rounds]
        cmd = [first_cmd.get(r, math.nan) - captures[r] for r in rounds]
    return {
        'benchmark': 'dj_rob_start', 'rounds_requested': opts.rounds,
        'rounds_captured': len(rounds), 'decisions': len(decisions),
        'dur_s': opts.dur, 'robot_clock': opts.robot_clock,
        'music_clock': opts.music_clock, 'start_spin_s': opts.spin,
        'realtime_priority': opts.realtime_priority,
        'dance_start_true_offset': stats(dance),
        'dance_abs_true_offset': stats([abs(v) for v in dance]),
        'first_command_arrival_offset': stats(cmd),
        'music_start_true_offset': stats(music),
        'music_abs_true_offset': stats([abs(v) for v in music]),
        'per_round_ms': {str(r): {'dance': round(d * 1e3, 3),
                                  'first_command': round(c * 1e3, 3),
                                  'music': round(m * 1e3, 3)}
                         for r, d, c, m in zip(rounds, dance, cmd, music)},
        'missing': {'dance': sum(1 for v in dance if not math.isfinite(v)),
                    'music': sum(1 for v in music if not math.isfinite(v))},
    }


if __name__ == '__main__':
    sys.exit(main())
