#!/usr/bin/env python3
"""A newcomer's first hour, as the README and the "add a sensor" guide
(docs/sensors.md) tell it: a sensor of one's own (a LaserScan on /scan)
through client.launch with the generic processor, a server that lists
it, two rounds recorded with rosbag as the guide says, then ``report``
on that bag with ``--export mcap``.  Checks what the newcomer reads: the
scans counted in each result equal those recorded, the result names its
unit, the MCAP holds the bag's messages, and the report passes without a
false failure.  Exit status 0: all of it held.

Run after ``source .ws/devel/setup.bash`` (``make test`` runs it).
"""
import json
import os
import re
import socket
import subprocess
import sys
import tempfile

import rosbag
import rospy

from hri_sync.msg import Decision
from hri_sync_support.harness import (Processes, free_port, wait_for_master,
                                      wait_until)

LIMIT = 300.0       # s for anything to happen on a loaded machine
RECORDED = ['/lidar/captured', '/client_result', '/capture_data',
            '/decision', '/lidar/clock_state']
FAILURES = []


def check(ok, what):
    print('%s %s' % ('ok  ' if ok else 'FAIL', what), flush=True)
    if not ok:
        FAILURES.append(what)


def record_two_rounds(procs, port, bag):
    ntp = str(free_port(kind=socket.SOCK_DGRAM))
    ros = ['roslaunch', '-p', str(port), 'hri_sync']
    procs.start('timeserver', ros + ['timeserver.launch', 'ntp_port:=' + ntp])
    procs.start('scanner', [
        'rostopic', 'pub', '-r', '20', '-s', '/scan', 'sensor_msgs/LaserScan',
        '{header: {stamp: now, frame_id: laser}, ranges: [1.0, 1.5]}'])
    recorder = procs.start('rosbag', ['rosbag', 'record', '-O', bag,
                                      '__name:=recorder'] + RECORDED)
    procs.start('client', ros + [
        'client.launch', 'client_id:=lidar', 'ntp_port:=' + ntp,
        'processor:=hri_sync.sensors.generic.HeaderCount',
        'processor_params:={msg_type: sensor_msgs/LaserScan}',
        'input:=/scan'])
    server = procs.start('server', ros + [
        'server.launch', 'clients:=lidar', 'rounds:=2', 'dur:=3.0',
        'ntp_port:=' + ntp, 'recorder:=recorder'])
    decisions = []
    rospy.Subscriber('/decision', Decision, decisions.append)
    wait_until('two decisions', lambda: len(decisions) >= 2, LIMIT,
               [('server', server), ('rosbag', recorder)])
    rospy.sleep(4.0)    # the captured scans follow their result (2 s)
    recorder.send_signal(2)
    recorder.wait(timeout=60)
    with open(os.path.join(procs.logdir, 'client.log')) as f:
        said = re.findall(r'round \d+ ok: .* value [0-9.]+ (\w+)', f.read())
    check(said and set(said) == {'messages'},
          'the client\'s log names the unit of its value: %s' % said)


def read_bag(bag):
    """{topic: [msg]} of the recording."""
    out = {}
    with rosbag.Bag(bag) as b:
        for topic, msg, _ in b.read_messages():
            out.setdefault(topic, []).append(msg)
    return out


def check_results(msgs):
    results = msgs.get('/client_result', [])
    check(len(results) == 2, '2 results recorded (%d)' % len(results))
    captured = msgs.get('/lidar/captured', [])
    frames = sum(r.frames for r in results)
    check(frames > 0 and frames == len(captured),
          'the scans counted in the results (%d) are those recorded (%d)'
          % (frames, len(captured)))
    for r in results:
        d = {kv.key: kv.value for kv in r.diagnostics}
        check(r.status == 'ok' and d.get('unit') == 'messages'
              and r.value == r.frames,
              'round %d: %s, value %g %s' % (r.round, r.status, r.value,
                                             d.get('unit')))


def check_report(bag, out, msgs):
    run = subprocess.run(['rosrun', 'hri_sync', 'report', bag, '--out', out,
                          '--export', 'mcap'], capture_output=True,
                         text=True, stdin=subprocess.DEVNULL, timeout=600)
    text = run.stdout + run.stderr
    print(text, flush=True)
    check(run.returncode == 0, 'report passes (exit %d)' % run.returncode)
    for false in ('NOT REPRODUCED', '0/2 decisions', 'no the ', 'issue',
                  'scored highest', 'CUT OFF'):
        check(false not in text, 'the report does not say %r' % false)
    check('decisions not recomputed' in text, 'the report says why its '
          'decisions were not recomputed')
    with open(os.path.join(out, 'summary.json')) as f:
        totals = json.load(f)['sessions'][0]['totals']
    check(totals['rounds'] == 2 and totals['decided'] == 2 and totals['ok'],
          'summary.json: 2 rounds, 2 decided, ok')
    from mcap.reader import make_reader
    counts = {}
    with open(bag[:-len('.bag')] + '.mcap', 'rb') as f:
        for _, channel, _ in make_reader(f).iter_messages():
            counts[channel.topic] = counts.get(channel.topic, 0) + 1
    want = {t: len(m) for t, m in msgs.items()}
    got = {t: n for t, n in counts.items() if not t.startswith('/viewers/')}
    check(got == want, 'the MCAP holds the bag\'s messages (and derived '
          '/viewers/ topics): %s' % counts)


def main():
    logdir = tempfile.mkdtemp(prefix='first_hour.')
    bag = os.path.join(logdir, 'lidar.bag')
    port = free_port()
    os.environ['ROS_MASTER_URI'] = 'http://localhost:%d' % port
    procs = Processes(logdir, dict(os.environ))
    try:
        core = procs.start('roscore', ['roscore', '-p', str(port)])
        wait_for_master(os.environ['ROS_MASTER_URI'], LIMIT,
                        [('roscore', core)])
        rospy.init_node('first_hour', disable_signals=True)
        record_two_rounds(procs, port, bag)
    except RuntimeError as e:
        check(False, str(e))
    finally:
        procs.stop()
    if not FAILURES:
        msgs = read_bag(bag)
        check_results(msgs)
        check_report(bag, os.path.join(logdir, 'report'), msgs)
    print('first_hour: %s (logs: %s)' % (
        'FAILED: ' + '; '.join(FAILURES) if FAILURES else 'passed', logdir))
    sys.exit(1 if FAILURES else 0)


if __name__ == '__main__':
    main()
