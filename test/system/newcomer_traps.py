#!/usr/bin/env python3
"""What a newcomer met on a fresh clone, each checked on a master of its
own: rosrun finds one copy of each node (no file system loop); a config
error ends the DPM with one message naming the valid keys and the nearest,
and its respawned copy stays down; a corrected processor_params replaces
the misspelt one; an unknown message type names the message packages,
not rosdep; a sensor whose samples the DPM refuses is named as such by
its CPM, not called silent.  Exit status 0: all as a user would want.

Run after ``source .ws/devel/setup.bash`` (``make test`` runs it).
"""
import os
import subprocess
import sys
import tempfile
import time

import rospy
from diagnostic_msgs.msg import DiagnosticArray

from hri_sync.msg import DpmState
from hri_sync_support.harness import (Processes, free_port, wait_for_master,
                                      wait_until)

GENERIC = 'hri_sync.sensors.generic.HeaderCount'
LIMIT = 240.0       # s for anything to happen on a loaded machine
FAILURES = []


def check(ok, what):
    print('%s %s' % ('ok  ' if ok else 'FAIL', what), flush=True)
    if not ok:
        FAILURES.append(what)


def rosrun_is_unique():
    for node in ('skeleton_adapter', 'lsl_inlet', 'rep155_bridge', 'report'):
        run = subprocess.run(['rosrun', '--prefix', 'echo', 'hri_sync', node],
                             stdin=subprocess.DEVNULL, capture_output=True,
                             text=True, timeout=120)
        out = run.stdout + run.stderr
        check(run.returncode == 0 and len(out.split()) == 1
              and 'loop' not in out and 'non-unique' not in out,
              'rosrun hri_sync %s finds one executable: %r' % (node, out))


def launch(procs, name, params, port):
    """client.launch of client t1 with the generic processor."""
    return procs.start(name, [
        'roslaunch', '-p', str(port), 'hri_sync', 'client.launch',
        'client_id:=t1', 'ntp_port:=%d' % free_port(), 'input:=/t1/scan',
        'processor:=' + GENERIC, 'processor_params:=' + params])


def log_of(procs, name):
    with open(os.path.join(procs.logdir, name + '.log')) as f:
        return f.read()


def stop(proc):
    proc.send_signal(2)
    try:
        proc.wait(timeout=60)
    except subprocess.TimeoutExpired:
        proc.kill()


def config_error_once(procs, port):
    """A misspelt key: one message, the valid keys, no respawn loop."""
    p = launch(procs, 'typo', '{msg_typ: sensor_msgs/Range}', port)
    wait_until('the DPM to stay down', lambda: 'stays down' in log_of(
        procs, 'typo'), LIMIT, [('roslaunch', p)])
    time.sleep(5.0)     # respawn_delay 1 s: a loop would show by now
    log = log_of(procs, 'typo')
    check(log.count("unknown key of HeaderCount 'msg_typ': valid: "
                    "msg_type; did you mean 'msg_type'?") == 1,
          'a misspelt key is told once, with the valid keys and the nearest')
    check(log.count('stays down') == 1 and 'TypeError' not in log,
          'the respawned DPM stays down')
    stop(p)


def unknown_type(procs, port):
    """An unknown message package: the valid ones, no rosdep advice."""
    p = launch(procs, 'pkg', '{msg_type: sensr_msgs/Range}', port)
    wait_until('the DPM to stay down', lambda: 'stays down' in log_of(
        procs, 'pkg'), LIMIT, [('roslaunch', p)])
    log = log_of(procs, 'pkg')
    check("unknown message package 'sensr_msgs'" in log
          and "did you mean 'sensor_msgs'?" in log and 'rosdep' not in log
          and "'msg_typ'" not in log,
          'an unknown message package is named with the nearest (and the '
          'earlier launch left no stale key)')
    stop(p)


def refused_samples(procs, port):
    """A LaserScan on a Range topic: the CPM says the DPM refuses it."""
    p = launch(procs, 'refused', '{msg_type: sensor_msgs/Range}', port)
    states, reasons = [], []
    rospy.Subscriber('/t1/dpm_state', DpmState, states.append)
    rospy.Subscriber('/diagnostics', DiagnosticArray, lambda m: reasons.extend(
        s.message for s in m.status if 'cpm' in s.name))
    wait_until('the DPM to start', lambda: states, LIMIT, [('roslaunch', p)])
    scans = procs.start('scans', [
        'rostopic', 'pub', '-r', '20', '-s', '/t1/scan',
        'sensor_msgs/LaserScan', '{header: {stamp: now, frame_id: laser}}'])
    wait_until('the CPM to name the refused samples', lambda: any(
        'delivers samples the DPM refuses' in r for r in reasons), LIMIT,
        [('roslaunch', p), ('rostopic', scans)])
    last = states[-1]
    check(last.refused > 0 and 'sensor_msgs/LaserScan' in
          last.refused_reason and not any('silent' in r for r in reasons[-3:]),
          'a sensor of the wrong type is named as such, not silent: %r'
          % last.refused_reason)
    stop(scans)
    stop(p)


def main():
    logdir = tempfile.mkdtemp(prefix='newcomer_traps.')
    port = free_port()
    os.environ['ROS_MASTER_URI'] = 'http://localhost:%d' % port
    procs = Processes(logdir, dict(os.environ))
    try:
        rosrun_is_unique()
        core = procs.start('roscore', ['roscore', '-p', str(port)])
        wait_for_master(os.environ['ROS_MASTER_URI'], LIMIT,
                        [('roscore', core)])
        rospy.init_node('newcomer_traps', disable_signals=True)
        config_error_once(procs, port)
        unknown_type(procs, port)
        refused_samples(procs, port)
    except RuntimeError as e:
        check(False, str(e))
    finally:
        procs.stop()
    print('newcomer_traps: %s (logs: %s)' % (
        'FAILED: ' + '; '.join(FAILURES) if FAILURES else 'passed', logdir))
    sys.exit(1 if FAILURES else 0)


if __name__ == '__main__':
    main()
