#!/usr/bin/python3
"""Benchmark: how close to their scheduled time action_client's actions begin.

Runs ROUNDS back-to-back rounds (time server, server, one sensor client,
action_client, optionally under a libfaketime clock) on a private ROS
master, with one action of each kind at the window start (a message, a
service call, an actionlib goal, a command: this process serves the
service and the action server) and a message on the decision (+0.2 s),
and prints JSON: per action, its start in true time (the node's raw
host-clock reading at the start, against the scheduled global time: the
time server serves this host's clock, so global = true), the arrival at
this process (includes ROS transport; the observer runs SCHED_FIFO when
permitted), and the statuses reported (ok, late, failed).

    source WS/devel/setup.bash
    bench/action_starts.py --rounds 10 --dur 2 [--client-clock '+2.5s x1.0002']
"""
import argparse
import json
import math
import os
import sys
import tempfile
import threading
import time
from collections import Counter

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__))), 'support'))
from hri_sync_support.harness import (  # noqa: E402
    add_start_args, one_client_launch, percentiles_ms as stats,
    run_private_launch)

INCLUDE = """<include file="$(find hri_sync)/launch/actions.launch">
    <arg name="actions" value="{actions}"/>
    <arg name="ntp_port" value="$(arg ntp_port)"/>
    <arg name="start_spin" value="{spin}"/>
    <arg name="realtime_priority" value="{rt}"/>
  </include>"""
SKEWED = """<node pkg="hri_sync" type="skewed_client" name="actions_clock"
        args="--clock '{clock}' actions.launch actions:={actions}
              ntp_port:=$(arg ntp_port) start_spin:={spin}
              realtime_priority:={rt}"/>"""
ACTIONS = """actions:
  - name: message
    at: window_start
    publish: {topic: /bench/message, type: std_msgs/String,
              fields: {data: start}}
  - name: service
    at: window_start
    service: {service: /action_bench/mark, type: std_srvs/Trigger}
  - name: goal
    at: window_start
    actionlib: {server: /action_bench/goal, type: actionlib/TwoIntsAction,
                goal: {a: 1, b: 2}}
  - name: command
    at: window_start
    command: [/bin/true]
  - name: decision
    at: decision
    offset: 0.2
    publish: {topic: /bench/decided, type: std_msgs/String,
              fields: {data: decided}}
"""
ARRIVING = ('message', 'service', 'goal', 'decision')


def launch_file(opts, workdir):
    actions = os.path.join(workdir, 'actions.yaml')
    with open(actions, 'w') as f:
        f.write(ACTIONS)
    fmt = SKEWED if opts.client_clock else INCLUDE
    client = fmt.format(actions=actions, clock=opts.client_clock,
                        spin=opts.spin, rt=opts.realtime_priority)
    path = os.path.join(workdir, 'bench.launch')
    with open(path, 'w') as f:
        f.write(one_client_launch('actions', opts.rounds, opts.dur,
                                  client))
    return path


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--rounds', type=int, default=10)
    ap.add_argument('--dur', type=float, default=2.0)
    ap.add_argument('--client-clock', default='')
    add_start_args(ap, 'action_client')
    opts = ap.parse_args()
    path = launch_file(opts, tempfile.mkdtemp(prefix='action_bench_'))
    result = run_private_launch(path, lambda proc: observe(opts, proc))
    print(json.dumps(result, indent=1))


class Observer:
    """The receivers of the actions, and their reports."""

    def __init__(self):
        import actionlib
        import rospy
        from actionlib.msg import TwoIntsAction, TwoIntsResult
        from std_msgs.msg import String
        from std_srvs.srv import Trigger, TriggerResponse
        from hri_sync.msg import ActionStart, CaptureData, Decision
        self.lock = threading.Lock()
        self.reports, self.arrivals, self.decisions = {}, {}, set()
        self.captured = 0          # the round whose window comes next
        rospy.Subscriber('/actions/action_start', ActionStart,
                         self.on_report, queue_size=100)
        rospy.Subscriber('/capture_data', CaptureData,
                         lambda m: setattr(self, 'captured', m.round))
        rospy.Subscriber('/decision', Decision,
                         lambda m: self.decisions.add(m.round))
        for topic, name in (('/bench/message', 'message'),
                            ('/bench/decided', 'decision')):
            rospy.Subscriber(topic, String, self.arrived, name,
                             tcp_nodelay=True)
        rospy.Service('~mark', Trigger, lambda req: (
            self.arrived(req, 'service'), TriggerResponse(success=True))[1])
        self.server = actionlib.SimpleActionServer(
            '~goal', TwoIntsAction, lambda g: (
                self.arrived(g, 'goal'),
                self.server.set_succeeded(TwoIntsResult(sum=3))),
            auto_start=False)
        self.server.start()

    def on_report(self, m):
        with self.lock:
            self.reports[(m.round, m.action)] = m

    def arrived(self, _msg, name):
        """An action reached this process: a window action belongs to
        the last capture order's round, the decision's to the last
        decision's."""
        t = time.time()
        with self.lock:
            n = max(self.decisions or {0}) if name == 'decision' else \
                self.captured
            self.arrivals.setdefault((n, name), t)

    def figures(self):
        with self.lock:
            reports, arrivals = dict(self.reports), dict(self.arrivals)
        out = {}
        for name in ('message', 'service', 'goal', 'command', 'decision'):
            mine = {r: m for (r, a), m in reports.items() if a == name}
            start = [m.true_time.to_sec() - m.scheduled.to_sec()
                     for m in mine.values()]
            row = {'reports': len(mine),
                   'status': dict(Counter(m.status for m in mine.values())),
                   'start_true_offset': stats(start)}
            if name in ARRIVING:
                row['arrival_offset'] = stats(
                    [arrivals.get((r, name), math.nan) - m.scheduled.to_sec()
                     for r, m in mine.items()])
            out[name] = row
        return out


def observe(opts, proc):
    import rosgraph
    import rospy
    from hri_sync.clock.truth import realtime
    deadline = time.time() + 30.0
    while not rosgraph.is_master_online() and time.time() < deadline:
        if proc.poll() is not None:
            sys.exit('action_starts: roslaunch exited (%d)' % proc.returncode)
        time.sleep(0.2)
    if not rosgraph.is_master_online():
        sys.exit('action_starts: no ROS master after 30 s')
    with realtime(5) as rt:
        pass
    if rt.ok:
        os.sched_setscheduler(0, os.SCHED_FIFO, os.sched_param(5))
    rospy.init_node('action_bench', disable_signals=True)
    obs = Observer()
    deadline = time.time() + 60 + opts.rounds * (opts.dur + 5)
    while time.time() < deadline and len(obs.decisions) < opts.rounds:
        time.sleep(0.2)
    time.sleep(1.0)
    figures = obs.figures()
    # The action server's thread runs until rospy shuts down.
    rospy.signal_shutdown('done')
    return {'benchmark': 'action_starts', 'rounds_requested': opts.rounds,
            'decisions': len(obs.decisions), 'dur_s': opts.dur,
            'client_clock': opts.client_clock, 'start_spin_s': opts.spin,
            'realtime_priority': opts.realtime_priority,
            'actions': figures}


if __name__ == '__main__':
    sys.exit(main())
