#!/usr/bin/python3
"""make test-site: the site launch files on four "machines" (JSON summary).

    source .ws/devel/setup.bash
    sudo /usr/bin/python3 test/system/site_multihost.py

Each machine is a Linux network namespace (its own loopback and ports) with
one veth link to a bridge in a switch namespace, on 10.78.0.0/24:

    server 10.78.0.1   roscore, then site_server.launch (chronyd serving
                       the subnet, CM, DM, music, round monitor, recording)
    left   10.78.0.11  site_client.launch client_id:=left (salsa replay)
    right  10.78.0.12  site_client.launch client_id:=right (a still person)
    robot  10.78.0.13  site_robot.launch robot:=sim

each started by its own roslaunch against the server's master, with
ROS_MASTER_URI, ROS_IP and master:=/ntp_server:= as a real machine would
have them. This script enters the server namespace and checks one round:
a decision with winner participant 1 (the dancer), both results ok,
DJ Rob's dance start reported and its winner gesture (dj_rob_monitor's
"gesture done" line, heading within 10 deg of participant 1); the
server's preflight verdict is reported, not judged (it depends on the
load). It also checks that a site file without master:= stops, naming
the arg. Needs root (ip netns). Every namespace and process it made is
removed on exit; namespaces of a killed earlier run are removed at start.
Exit 0 on pass; the logs are kept (and named) on a failure.
"""
import ctypes
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time

CLONE_NEWNET = 0x40000000
PREFIX = 'hrisite'              # namespaces hrisite<pid>-<host>
NET = '10.78.0'
HOSTS = {'server': 1, 'left': 11, 'right': 12, 'robot': 13}
MASTER = 'http://%s.1:11311' % NET
NTP_PORT = 11123                # each namespace has its own ports
TIMEOUT = 240.0                 # s for the whole round
MAX_HEADING_ERROR = 10.0        # deg


def log(fmt, *args):
    print('site_multihost: ' + fmt % args, file=sys.stderr, flush=True)


def ip(*argv):
    r = subprocess.run(['ip'] + list(argv), capture_output=True, text=True,
                       timeout=10)
    if r.returncode:
        raise RuntimeError('ip %s: %s' % (' '.join(argv), r.stderr.strip()))
    return r.stdout


def kill(pids):
    """SIGKILL each pid still alive (not this process, which lives in the
    server namespace)."""
    for pid in pids:
        if int(pid) == os.getpid():
            continue
        try:
            os.kill(int(pid), signal.SIGKILL)
        except ProcessLookupError:
            pass


def remove_stale():
    """Namespaces of earlier runs whose process is gone."""
    for line in ip('netns', 'list').splitlines():
        name = line.split()[0] if line.strip() else ''
        m = re.match(r'^%s(\d+)-' % PREFIX, name)
        if m and not os.path.exists('/proc/%s' % m.group(1)):
            kill(ip('netns', 'pids', name).split())
            ip('netns', 'del', name)
            log('removed stale namespace %s', name)


class Site:
    """The namespaces, the processes started in them, and their logs."""

    def __init__(self, logdir):
        self.tag = '%s%d' % (PREFIX, os.getpid())
        self.logdir = logdir
        self.made = []
        self.procs = []

    def ns(self, host):
        return '%s-%s' % (self.tag, host)

    def build(self):
        sw = self.ns('sw')
        for name in [sw] + [self.ns(h) for h in HOSTS]:
            ip('netns', 'add', name)
            self.made.append(name)
            ip('-n', name, 'link', 'set', 'lo', 'up')
        ip('-n', sw, 'link', 'add', 'br0', 'type', 'bridge')
        ip('-n', sw, 'link', 'set', 'br0', 'up')
        for host, last in HOSTS.items():
            ip('-n', sw, 'link', 'add', 'p-' + host, 'type', 'veth', 'peer',
               'name', 'eth0', 'netns', self.ns(host))
            ip('-n', sw, 'link', 'set', 'p-' + host, 'master', 'br0', 'up')
            ip('-n', self.ns(host), 'addr', 'add', '%s.%d/24' % (NET, last),
               'dev', 'eth0')
            ip('-n', self.ns(host), 'link', 'set', 'eth0', 'up')

    def start(self, host, name, argv):
        """argv in host's namespace, as that machine would run it."""
        env = dict(os.environ, ROS_MASTER_URI=MASTER,
                   ROS_IP='%s.%d' % (NET, HOSTS[host]),
                   ROS_LOG_DIR=os.path.join(self.logdir, 'ros'),
                   ROS_HOME=os.path.join(self.logdir, 'ros'),
                   PYTHONUNBUFFERED='1')
        env.pop('ROS_HOSTNAME', None)
        out = open(os.path.join(self.logdir, name + '.log'), 'w')
        p = subprocess.Popen(['ip', 'netns', 'exec', self.ns(host)] + argv,
                             env=env, stdout=out, stderr=subprocess.STDOUT,
                             start_new_session=True)
        self.procs.append((name, p))
        return p

    def output(self, name):
        with open(os.path.join(self.logdir, name + '.log')) as f:
            return f.read()

    def stop(self):
        for _, p in reversed(self.procs):
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGINT)
        deadline = time.monotonic() + 15.0
        for _, p in self.procs:
            try:
                p.wait(max(0.1, deadline - time.monotonic()))
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait()
        for name in self.made:
            kill(ip('netns', 'pids', name).split())
        for name in reversed(self.made):
            ip('netns', 'del', name)


def enter(ns):
    """Move this (still single-threaded) process into namespace ns."""
    libc = ctypes.CDLL(None, use_errno=True)
    fd = os.open('/run/netns/' + ns, os.O_RDONLY)
    try:
        if libc.setns(fd, CLONE_NEWNET):
            raise OSError(ctypes.get_errno(), 'setns ' + ns)
    finally:
        os.close(fd)


def launch(name, *args):
    return ['roslaunch', '--wait', 'hri_sync', name,
            'master:=' + MASTER, 'ntp_server:=%s.1' % NET,
            'ntp_port:=%d' % NTP_PORT] + list(args)


def check_missing_master(site):
    """site_client.launch without master:= stops and names the arg."""
    p = site.start('left', 'missing_master', [
        'roslaunch', 'hri_sync', 'site_client.launch',
        'ntp_server:=%s.1' % NET, 'client_id:=left', 'motion:=x'])
    p.wait(60)
    out = site.output('missing_master')
    return p.returncode != 0 and "'master'" in out


def run(site, result):
    site.build()
    enter(site.ns('server'))
    os.environ.update(ROS_MASTER_URI=MASTER, ROS_IP='%s.1' % NET)
    site.start('server', 'roscore', ['roscore', '-p', '11311'])
    result['missing_master_named'] = check_missing_master(site)
    site.start('server', 'server', launch(
        'site_server.launch', 'allow:=%s.0/24' % NET, 'rounds:=1',
        'dur:=3', 'connect_timeout:=60', 'bag:=%s/round.bag' % site.logdir))
    site.start('left', 'left', launch(
        'site_client.launch', 'client_id:=left', 'motion:=cmu_60_01_salsa',
        'seed:=4'))
    site.start('right', 'right', launch(
        'site_client.launch', 'client_id:=right', 'motion:=cmu_61_01_salsa',
        'hold:=3.0', 'seed:=21'))
    robot = site.start('robot', 'robot', launch(
        'site_robot.launch', 'robot:=sim', 'rounds:=1',
        'monitor_required:=true'))

    import rospy    # after setns: its sockets live in the server namespace
    from hri_sync.msg import ActionStart, ClientResult, Decision
    got = {'results': {}, 'decision': None, 'dance': None}
    lock = threading.Lock()

    def keep(key):
        def on(msg):
            with lock:
                if key == 'results':
                    got['results'][msg.client_id] = msg.status
                else:
                    got[key] = msg
        return on
    rospy.init_node('site_multihost_check', disable_signals=True)
    rospy.Subscriber('/client_result', ClientResult, keep('results'))
    rospy.Subscriber('/decision', Decision, keep('decision'))
    rospy.Subscriber('/dj_rob/action_start', ActionStart, keep('dance'))
    deadline = time.monotonic() + TIMEOUT
    while robot.poll() is None and time.monotonic() < deadline:
        time.sleep(0.5)
    with lock:
        d, dance = got['decision'], got['dance']
        result['results'] = dict(got['results'])
    result['decision'] = None if d is None else {
        'outcome': d.outcome, 'winner': d.winner, 'reason': d.reason}
    result['dance_start_offset_ms'] = (None if dance is None
                                       else round(dance.offset * 1e3, 3))
    m = re.search(r'gesture done.*participant (\d) at .* off by ([\d.]+) deg',
                  site.output('robot'))
    result['gesture'] = None if m is None else {
        'participant': int(m.group(1)), 'off_deg': float(m.group(2))}
    result['robot_launch_exit'] = robot.poll()
    verdict = re.search(r'^preflight: .*$', site.output('server'), re.M)
    result['preflight'] = verdict.group(0) if verdict else None
    rospy.signal_shutdown('done')


def passed(r):
    return (r.get('missing_master_named') is True
            and r.get('results') == {'left': 'ok', 'right': 'ok'}
            and (r.get('decision') or {}).get('outcome') == 'winner'
            and r['decision']['winner'] == 1
            and r.get('dance_start_offset_ms') is not None
            and (r.get('gesture') or {}).get('participant') == 1
            and r['gesture']['off_deg'] <= MAX_HEADING_ERROR
            and r.get('robot_launch_exit') == 0)


def main():
    if os.geteuid() != 0:
        sys.exit('site_multihost: needs root (ip netns)')
    remove_stale()
    logdir = tempfile.mkdtemp(prefix='hri_sync_site_')
    site = Site(logdir)
    result = {'logs': logdir}
    try:
        run(site, result)
    except Exception as e:      # reported, then the site is torn down
        result['error'] = '%s: %s' % (type(e).__name__, e)
    finally:
        site.stop()
    ok = passed(result) and 'error' not in result
    if ok:
        shutil.rmtree(logdir)
        result['logs'] = None
    log('%s%s', 'PASS' if ok else 'FAIL', '' if ok else ' (logs in %s)'
        % logdir)
    print(json.dumps(result))
    sys.exit(0 if ok else 1)


if __name__ == '__main__':
    main()
