#!/usr/bin/python3
"""Record the session bags of test/bags/ that the report's tests read.

Each is a whole dance-off session recorded by ``dance_off.launch bag:=``
(DJ Rob on the simulated base, the music, 3 s windows, bz2):

  session_robot   2 rounds: salsa (left) against a still person: winner 1
  session_still   1 round: two still people: no_winner; with the raw
                  sensor streams (record_raw)

Run it in a sourced workspace (``source .ws/devel/setup.bash``) after a
change to msg/, so the tests read bags of the current messages:

    /usr/bin/python3 scripts/make_session_bags.py [--out test/bags] [NAME...]

session_robot.bag is kept as recorded before the timestamped messages got
a std_msgs/Header (test/unit/test_pre_header.py reads it as an old
recording), so it is made only when named.

Each launch runs on its own ROS master and time-server port; the output
of each is in OUT/<name>.log (removed on success).
"""
import argparse
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, 'support'))
from hri_sync_support.harness import free_port  # noqa: E402

COMMON = ['dur:=3', 'bag_options:=--bz2']
SESSIONS = {
    'session_robot': ['rounds:=2', 'right_hold:=0', 'left_seed:=1',
                      'right_seed:=2'],
    'session_still': ['rounds:=1', 'left_hold:=0', 'right_hold:=0',
                      'left_seed:=3', 'right_seed:=4', 'record_raw:=true'],
}

# Shipped recordings of older message definitions, kept on purpose.
KEPT = ('session_robot',)



def record(name, args, out):
    bag = os.path.join(out, name + '.bag')
    if os.path.exists(bag):
        os.remove(bag)
    port = free_port()
    log = os.path.join(out, name + '.log')
    cmd = ['roslaunch', '-p', str(port), 'hri_sync', 'dance_off.launch',
           'bag:=' + bag, 'ntp_port:=%d' % free_port()] + COMMON + args
    print(' '.join(cmd), flush=True)
    env = dict(os.environ, ROS_MASTER_URI='http://localhost:%d' % port)
    with open(log, 'w') as f:
        done = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT,
                              env=env, timeout=300)
    if done.returncode != 0 or not os.path.exists(bag):
        sys.exit('%s: roslaunch failed (exit %d), see %s'
                 % (name, done.returncode, log))
    os.remove(log)
    print('%s: %d bytes' % (bag, os.path.getsize(bag)))


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--out', default=os.path.join(ROOT, 'test', 'bags'))
    parser.add_argument('names', nargs='*', metavar='NAME',
                        help='of %s (default: all but %s)'
                        % (', '.join(sorted(SESSIONS)), ', '.join(KEPT)))
    args = parser.parse_args()
    unknown = set(args.names) - set(SESSIONS)
    if unknown:
        parser.error('unknown session(s): %s' % ', '.join(sorted(unknown)))
    args.names = args.names or sorted(set(SESSIONS) - set(KEPT))
    for name in args.names:
        record(name, SESSIONS[name], args.out)


if __name__ == '__main__':
    main()
