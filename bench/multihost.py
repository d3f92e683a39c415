#!/usr/bin/python3
"""Start skew of N clients on separate network namespaces ("hosts") (JSON).

    source <ws>/devel/setup.bash
    sudo /usr/bin/python3 bench/multihost.py --clients 2 --rounds 10

The multi-host variant of ``bench/sync_skew.py`` (both are
``hri_sync_support.skew_bench`` with their own command wrappers):
every "host" is a Linux network namespace of its own, with its own
loopback and one veth link to a bridge in a switch namespace, addresses in
``--net`` (default 10.77.0.0/24; nothing leaves the namespaces it creates):

- the server namespace (first address, ``.1``): a roscore, chronyd
  (``timeserver.launch`` bound to the server's address, ``allow`` = the
  subnet), the reference ``synthetic_sensor`` on the true clock, the
  server (``server.launch``, ``ntp_server`` = the server's address), and
  this bench itself (it enters the server namespace to record the rounds);
- one namespace per client (``.11``, ``.12``, ...): ``client.launch``
  under one libfaketime clock with a random offset and drift
  (``skewed_client``), ``ROS_MASTER_URI`` and ``ntp_server`` pointing at
  the server across the link, its DPM reading the reference across the
  link with ``stamp_source: arrival`` (with ``--sensors own``: its own
  sensor on the true clock in its namespace; ``--stamp-source device``:
  the sensor's device stamp mapped to global time).

``--shape c1`` puts a ``tc tbf`` (``--shape-rate``, ``--shape-latency``)
on both directions of that client's link, and ``--load-kbit`` sends a UDP
flow from the server to that client through it, to add queueing (from
when the clients are synced, or with ``--load-at start`` from before they
start).

Needs root (``ip netns``).  Progress goes to stderr; the last stdout line
is one JSON object with the figures of ``sync_skew.py`` plus the network.
Every process it started is stopped and every namespace it made is deleted
on exit, on Ctrl-C and when --timeout runs out (namespaces left by a
killed earlier run are deleted at start).  Exit status 0 when every round
produced a full set of OK results, 1 otherwise, 2 when the setup failed,
130 when interrupted.
"""
import argparse
import ctypes
import functools
import ipaddress
import os
import random
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time

sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__))), 'support'))
from hri_sync_support import skew_bench  # noqa: E402
from hri_sync.clock.skew import percentiles
from hri_sync_support import harness  # noqa: E402

CLONE_NEWNET = 0x40000000
MASTER_PORT = 11311     # each namespace has its own ports
NTP_PORT = 11123
NETNS_SETUP = 15.0      # s more for the namespaces
NS_PREFIX = 'hrims'     # namespaces are hrims<bench pid>-<host>
NS_RE = re.compile(r'^%s(\d+)-' % NS_PREFIX)

# A paced UDP flow: argv destination, kbit/s.  Port 9 (discard): the
# client's kernel drops it, after it crossed the shaped link.
LOAD_PROGRAM = r'''
import socket, sys, time
dst, rate = (sys.argv[1], 9), float(sys.argv[2]) * 1000 / 8
size = 1000
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
t = time.monotonic()
while True:
    try:
        s.sendto(b'\0' * size, dst)
    except OSError:
        pass
    t += size / rate
    d = t - time.monotonic()
    if d > 0:
        time.sleep(d)
'''


def log(fmt, *args):
    print('multihost: ' + (fmt % args if args else fmt), file=sys.stderr,
          flush=True)


def ip(*argv):
    """Run ``ip ARGV`` (or ``tc`` when argv[0] == 'tc'); RuntimeError with
    its message on failure."""
    cmd = list(argv) if argv[0] == 'tc' else ['ip'] + list(argv)
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=10)
    if r.returncode != 0:
        raise RuntimeError('%s: %s' % (' '.join(cmd),
                                       (r.stderr or r.stdout).strip()))
    return r.stdout


def pid_alive(pid):
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        pass
    return True


def remove_stale_namespaces():
    """Delete the namespaces of earlier runs whose bench is dead (killed
    with SIGKILL), and kill the processes still running in them."""
    for line in ip('netns', 'list').splitlines():
        name = line.split()[0] if line.strip() else ''
        m = NS_RE.match(name)
        if m and not pid_alive(int(m.group(1))):
            pids = [int(p) for p in ip('netns', 'pids', name).split()]
            log('deleting namespace %s of a dead earlier run%s', name,
                ' and killing its processes %s' % pids if pids else '')
            for pid in pids:
                try:
                    os.kill(pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
            try:
                ip('netns', 'del', name)
            except RuntimeError as e:
                log('WARNING: %s', e)


class Network:
    """A switch namespace with a bridge, and hosts: each a namespace with
    ``eth0`` (veth to the bridge) at an address of the subnet."""

    def __init__(self, net):
        self.net = net
        self.tag = '%s%d' % (NS_PREFIX, os.getpid())
        self.switch = self.tag + '-sw'
        self.made = []          # namespaces, in creation order
        self.hosts = {}         # host -> (namespace, address)
        self.shaped = None

    def _netns(self, name):
        ip('netns', 'add', name)
        self.made.append(name)
        ip('-n', name, 'link', 'set', 'lo', 'up')

    def create_switch(self):
        self._netns(self.switch)
        ip('-n', self.switch, 'link', 'add', 'br0', 'type', 'bridge')
        ip('-n', self.switch, 'link', 'set', 'br0', 'up')

    def add_host(self, host, address):
        ns = '%s-%s' % (self.tag, host)
        self._netns(ns)
        port = 'p-' + host
        ip('-n', self.switch, 'link', 'add', port, 'type', 'veth', 'peer',
           'name', 'eth0', 'netns', ns)
        ip('-n', self.switch, 'link', 'set', port, 'master', 'br0', 'up')
        ip('-n', ns, 'addr', 'add', '%s/%d' % (address, self.net.prefixlen),
           'dev', 'eth0')
        ip('-n', ns, 'link', 'set', 'eth0', 'up')
        self.hosts[host] = (ns, str(address))
        return ns

    def shape(self, host, rate, latency):
        """tbf on both directions of ``host``'s link."""
        ns = self.hosts[host][0]
        for where, dev in ((ns, 'eth0'), (self.switch, 'p-' + host)):
            ip('tc', '-n', where, 'qdisc', 'add', 'dev', dev, 'root', 'tbf',
               'rate', rate, 'burst', '4kb', 'latency', latency)
        self.shaped = {'host': host, 'rate': rate, 'latency': latency}

    def qdisc_stats(self):
        """tc -s of the shaped link (drops, backlog), for the report."""
        if not self.shaped:
            return None
        host = self.shaped['host']
        out = {}
        for side, (where, dev) in (('to_server', (self.hosts[host][0],
                                                  'eth0')),
                                   ('to_client', (self.switch,
                                                  'p-' + host))):
            try:
                text = ip('tc', '-s', '-n', where, 'qdisc', 'show', 'dev',
                          dev)
            except RuntimeError as e:
                out[side] = str(e)
                continue
            m = re.search(r'Sent (\d+) bytes (\d+) pkt \(dropped (\d+), '
                          r'overlimits (\d+)', text)
            out[side] = ({'bytes': int(m.group(1)), 'packets': int(m.group(2)),
                          'dropped': int(m.group(3)),
                          'overlimits': int(m.group(4))} if m else text)
        return out

    def destroy(self):
        for name in reversed(self.made):
            try:
                ip('netns', 'del', name)
            except RuntimeError as e:
                log('WARNING: %s', e)
        left = [n for n in self.made
                if n in ip('netns', 'list').split()]
        if left:
            log('WARNING: namespaces left: %s', ', '.join(left))
        self.made = []


def enter_netns(name):
    """Move this (still single-threaded) process into namespace ``name``:
    the threads and sockets rospy makes afterwards live there."""
    libc = ctypes.CDLL(None, use_errno=True)
    fd = os.open('/run/netns/' + name, os.O_RDONLY)
    try:
        if libc.setns(fd, CLONE_NEWNET) != 0:
            err = ctypes.get_errno()
            raise RuntimeError('setns into %s: %s' % (name,
                                                      os.strerror(err)))
    finally:
        os.close(fd)


def in_ns(net, host, argv):
    """``argv`` run in ``host``'s namespace with ROS_IP = its address
    (``ip netns exec`` and ``env`` exec, so the pid stays the process's)."""
    ns, address = net.hosts[host]
    return ['ip', 'netns', 'exec', ns, 'env', 'ROS_IP=%s' % address] + argv


def run(bench, net):
    """Make the hosts, start everything and record the rounds."""
    args, procs, result = bench.args, bench.procs, bench.result
    clients = bench.clients
    deadline = time.monotonic() + result['timeout_s']
    rng = random.Random(args.seed)
    addresses = list(args.net.hosts())
    server_ip = str(addresses[0])

    net.create_switch()
    net.add_host('server', addresses[0])
    for i, c in enumerate(clients):
        net.add_host(c, addresses[10 + i])
    if args.shape:
        net.shape(args.shape, args.shape_rate, args.shape_latency)
    result['network'] = {
        'subnet': str(args.net), 'switch': net.switch,
        'hosts': {h: {'netns': ns, 'address': a}
                  for h, (ns, a) in net.hosts.items()},
        'shaped': net.shaped, 'load_kbit': args.load_kbit,
        'load_at': args.load_at if args.load_kbit else None}
    log('namespaces: %s', ', '.join('%s %s' % (ns, a) for ns, a in
                                    net.hosts.values()))
    enter_netns(net.hosts['server'][0])

    on_server = bench.wrap('server')
    master_uri = procs.env['ROS_MASTER_URI']
    bench.start_ros(on_server(['roscore', '-p', str(MASTER_PORT)]),
                    master_uri)
    bench.start_time_server(server_ip, NTP_PORT,
                            ['bind_address:=%s' % server_ip,
                             'allow:=%s' % args.net])
    log('roscore %s, chronyd on %s:%d', master_uri, server_ip, NTP_PORT)
    bench.start_sensors()

    def start_load():
        bench.started.append(('load', procs.start('load', on_server([
            sys.executable, '-c', LOAD_PROGRAM, net.hosts[args.shape][1],
            str(args.load_kbit)]))))
    if args.load_kbit > 0 and args.load_at == 'start':
        start_load()
    ntp_args = ['ntp_server:=%s' % server_ip, 'ntp_port:=%d' % NTP_PORT]
    for c in clients:
        if args.max_offset or args.max_drift:
            bench.clocks[c] = harness.random_clock(
                rng, args.max_offset, args.max_drift, time.time())
            log('client %s (%s): faketime %r', c, net.hosts[c][1],
                bench.clocks[c].spec)
        else:
            bench.clocks[c] = harness.TRUE_CLOCK
            log('client %s (%s): true clock', c, net.hosts[c][1])
        bench.start_client(c, ntp_args)
    bench.wait_clients()
    if args.load_kbit > 0 and args.load_at == 'rounds':
        start_load()
    bench.start_server(ntp_args)
    bench.record_rounds(deadline, wake=False)


def ack_uncertainties(bench):
    """{client: [ACK uncertainty, s]} over the rounds (half the best NTP
    round trip across the link, plus the fit's residual)."""
    out = {c: [] for c in bench.clocks}
    if bench.rlog is None:
        return out
    with bench.rlog.lock:
        for r in bench.rlog.rounds.values():
            for c, a in r['acks'].items():
                if c in out and a.ok:
                    out[c].append(a.uncertainty)
    return out


def clock_uncertainties(bench):
    """{client: [ClockState uncertainty, s]} in the order published (every
    resync; the model's bound: best half round trip + largest residual)."""
    if bench.rec is None:
        return {}
    return {c: [m.uncertainty for _, m in v]
            for c, v in sorted(bench.rec.clock_states.items())}


def stamp_errors(bench):
    """{client: [global stamp - true time, s]} of every sample the client
    kept: its clock error plus that sample's transport delay (queueing
    included; ``start_skew`` takes the minimum of the first ten)."""
    if bench.rlog is None:
        return {}
    out = {}
    with bench.rlog.lock:
        for r in bench.rlog.rounds.values():
            for c, kept in r['captured'].items():
                out.setdefault(c, []).extend(g - t for g, t, _ in kept)
    return dict(sorted(out.items()))


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    skew_bench.add_args(p, 10, 'clock offsets within +/- this, s (default '
                        '3; 0 with --max-drift 0: clients on the true '
                        'clock)')
    p.add_argument('--net', type=ipaddress.ip_network,
                   default=ipaddress.ip_network('10.77.0.0/24'),
                   help='subnet of the hosts (default 10.77.0.0/24)')
    p.add_argument('--shape', metavar='CLIENT', default=None,
                   help='put a tbf on both directions of this client\'s '
                   'link (e.g. c1)')
    p.add_argument('--shape-rate', default='1mbit',
                   help='tbf rate (default 1mbit)')
    p.add_argument('--shape-latency', default='20ms',
                   help='tbf latency: the most a packet queues (default '
                   '20ms)')
    p.add_argument('--load-kbit', type=float, default=0.0,
                   help='UDP flow server -> the shaped client, kbit/s '
                   '(default 0)')
    p.add_argument('--load-at', choices=('start', 'rounds'),
                   default='rounds',
                   help='start the load before the clients start (their '
                   'first NTP bursts cross the queue) or once they are '
                   'synced, before round 1 (default)')
    skew_bench.add_run_args(p)
    args = p.parse_args()
    skew_bench.check_args(p, args)
    if args.net.version != 4 or args.net.num_addresses < 16 + args.clients:
        p.error('--net must be an IPv4 subnet with room for %d hosts'
                % (11 + args.clients))
    if args.shape and args.shape not in ['c%d' % (i + 1)
                                         for i in range(args.clients)]:
        p.error('--shape must name a client, c1 .. c%d' % args.clients)
    if args.load_kbit < 0 or (args.load_kbit and not args.shape):
        p.error('--load-kbit needs --shape and must be >= 0')
    if args.max_offset < 0 or args.max_drift < 0:
        p.error('--max-offset and --max-drift must be >= 0')
    return args


def main():
    args = parse_args()
    if os.geteuid() != 0:
        sys.exit('multihost: needs root (ip netns); run it with sudo')
    for tool in ('ip', 'tc', 'roscore', 'roslaunch', 'faketime'):
        if shutil.which(tool) is None:
            sys.exit('multihost: %s is not installed' % tool)
    started = time.monotonic()
    logdir = tempfile.mkdtemp(prefix='hri_sync_multihost_')
    server_ip = str(next(args.net.hosts()))
    master_uri = 'http://%s:%d' % (server_ip, MASTER_PORT)
    env = dict(os.environ, ROS_MASTER_URI=master_uri, ROS_LOG_DIR=logdir,
               ROS_HOME=logdir, PYTHONUNBUFFERED='1')
    env.pop('ROS_HOSTNAME', None)
    env.pop('ROS_IP', None)
    os.environ.update(ROS_MASTER_URI=master_uri, ROS_LOG_DIR=logdir,
                      ROS_IP=server_ip)
    os.environ.pop('ROS_HOSTNAME', None)
    procs = harness.Processes(logdir, env, log)
    net = Network(args.net)
    bench = skew_bench.SkewBench(
        'multihost_bench', args, procs, log,
        args.timeout or skew_bench.time_budget(args) + NETNS_SETUP,
        lambda host: functools.partial(in_ns, net, host))

    def setup_and_run():
        remove_stale_namespaces()
        run(bench, net)

    def stop():
        qdisc = net.qdisc_stats()
        procs.stop()
        net.destroy()
        if qdisc:
            bench.result['network']['shaped_link_stats'] = qdisc

    def more():
        unc = ack_uncertainties(bench)
        return dict(
            ack_uncertainty_ms={c: harness.ms(percentiles(v)) if v else None
                                for c, v in sorted(unc.items())},
            sample_stamp_error_ms={
                c: harness.ms(dict(percentiles(v), min=min(v)))
                for c, v in stamp_errors(bench).items() if v},
            clock_state_uncertainty_ms={
                c: [round(u * 1e3, 3) for u in v]
                for c, v in clock_uncertainties(bench).items()})
    bench.main(setup_and_run, stop, logdir, started, more)


if __name__ == '__main__':
    main()
