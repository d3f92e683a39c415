#!/usr/bin/python3
"""`make demo`: one dance-off round on the real motion shipped in the repo.

Runs launch/dance_off.launch on its own ROS master: the left client's
sensor replays a salsa dancer (cmu_60_01_salsa), the right one a person
who barely moves (cmu_61_01_salsa at 5 % speed); both clients run with
wrong, drifting clocks under libfaketime (+1.2 s at +200 ppm, -0.8 s at
-200 ppm), measure them against the time server and capture the same
synchronized window; the round monitor prints both scores, the
decision and the start skew; the decision module's line gives the
decision's latency after the window's end and the round's timing
uncertainty; the round is recorded to a bag, which verify_decisions then
recomputes. Exits non-zero if the round or the verification fails.
Options pass on to the launch file as name:=value.
"""
import os
import re
import subprocess
import sys
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__))), 'support'))
from hri_sync_support.harness import free_port  # noqa: E402

HERE = os.path.dirname(os.path.abspath(__file__))
# The round reports of round_monitor and dj_rob_monitor (a header, then
# indented lines), and any error.
HEADER = re.compile(r'round \d+$|DJ Rob, round ')
ERROR = re.compile(r'.*\[(ERROR|FATAL)\]')
# The decision module's log line of a decision (nodes/decision_module).
DECISION = re.compile(r'.*round (\d+) decision: .*; on (.+), ([-\d.]+) ms '
                      r'after the window end; timing uncertainty '
                      r'([\d.na]+) ms')



def main():
    bag = os.path.join('/tmp', 'hri_sync_demo_%s.bag'
                       % time.strftime('%Y%m%d_%H%M%S'))
    args = ['left_motion:=cmu_60_01_salsa',
            'right_motion:=cmu_61_01_salsa', 'right_speed:=0.05',
            'right_offset:=3.0', 'dur:=10', 'rounds:=1', 'bag:=' + bag,
            'left_clock:=+1.2s x1.0002', 'right_clock:=-0.8s x0.9998',
            'ntp_port:=%d' % free_port()] + sys.argv[1:]
    port = free_port()
    env = dict(os.environ, ROS_MASTER_URI='http://localhost:%d' % port)
    log_path = bag[:-len('.bag')] + '.log'
    print('dance-off demo: roslaunch hri_sync dance_off.launch %s\n'
          '(the full roslaunch output goes to %s)\n'
          % (' '.join(args), log_path), flush=True)
    with open(log_path, 'w') as log:
        launch = subprocess.Popen(
            ['roslaunch', '-p', str(port), 'hri_sync', 'dance_off.launch']
            + args, env=env, stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT, text=True)
        in_report = False
        for line in launch.stdout:
            log.write(line)
            decided = DECISION.match(line)
            if decided:
                n, why, latency, uncertainty = decided.groups()
                print('round %s: decision %s ms after the window\'s end '
                      '(on %s; the server\'s global clock), timing '
                      'uncertainty %s ms' % (n, latency, why, uncertainty),
                      flush=True)
            in_report = bool(HEADER.match(line)) or (
                in_report and line.startswith('  '))
            if in_report or ERROR.match(line):
                sys.stdout.write(line)
                sys.stdout.flush()
        launch.wait()
    if launch.returncode != 0:
        sys.exit('dance-off demo: roslaunch failed (exit %d)'
                 % launch.returncode)
    if not os.path.exists(bag):
        sys.exit('dance-off demo: no bag was recorded at %s' % bag)
    print('\nverify_decisions %s' % bag, flush=True)
    tool = os.path.join(os.path.dirname(HERE), 'nodes', 'verify_decisions')
    verify = subprocess.run(['/usr/bin/python3', tool, bag])
    sys.exit(verify.returncode)


if __name__ == '__main__':
    main()
