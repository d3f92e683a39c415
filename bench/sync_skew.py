#!/usr/bin/python3
"""Start skew of N skewed clients against the true clock (JSON).

    source <ws>/devel/setup.bash
    /usr/bin/python3 bench/sync_skew.py --clients 2 --rounds 20

Starts, on free ports of its own: a roscore, chronyd (time_server node) as
the global time server, a reference synthetic_sensor on the true clock
(``signal: true_time``), N clients (CPM + DPM, ``client.launch``) each
under one libfaketime clock with a random offset (+/- --max-offset s) and
drift (+/- --max-drift ppm) via ``skewed_client``, reading the reference
with ``stamp_source: arrival``, then the server (control and decision
modules, ``rounds:=R``).  The bench itself is a ROS node on the true
clock: it records every round (``hri_sync.ros.RoundLog``) and, from
the samples each client kept (global stamp vs the true time written into
the sample), each client's clock error at the window start
(``hri_sync.timing.skew``).

Progress goes to stderr; the last stdout line is one JSON object.  Every
process it started (and their descendants, each in its own process group)
is stopped on exit, on Ctrl-C and when --timeout runs out.  Exit status 0
when every round produced a full set of OK results, 1 otherwise (the JSON
says what failed), 2 when the setup failed, 130 when interrupted.
"""
import argparse
import ctypes
import json
import math
import os
import random
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections import Counter
from xmlrpc.client import ServerProxy

import rosgraph
import roslib.packages
import rospy

from hri_sync.timing import ntp
from hri_sync.msg import (ClientResult, ClockState, Decision, RoundStatus,
                          SyncAck, SyncTime)
from hri_sync.ros.clock_state import model_from_msg
from hri_sync.ros.round_log import RoundLog
from hri_sync.timing.protocol import Capture
from hri_sync.timing.skew import client_timing, percentiles, start_skew

PR_SET_CHILD_SUBREAPER = 36
SETUP_TIME = 30.0        # s for roscore, chronyd and the sensor
SETUP_PER_CLIENT = 6.0   # s more per client


class Interrupted(Exception):
    """SIGINT, SIGTERM, SIGHUP or the run-time bound."""


def log(fmt, *args):
    print('sync_skew: ' + (fmt % args if args else fmt), file=sys.stderr,
          flush=True)


def free_port(kind):
    """A free port chosen by the kernel (random ephemeral), TCP or UDP."""
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind(('127.0.0.1', 0))
        return s.getsockname()[1]


def ms(stats):
    """Seconds -> ms in a percentiles dict, NaN -> None (valid JSON)."""
    return {k: round(v * 1e3, 4) if math.isfinite(v) else None
            for k, v in stats.items()}


def fail(failures, kind, fmt, *args):
    """Append a failure (kind, note) to ``failures``."""
    failures.append((kind, fmt % args))


def median(values):
    """The nearest-rank median, None for none."""
    return percentiles(values)['p50'] if values else None


def mean_ms(values):
    """Mean of seconds in ms (None for none)."""
    return round(sum(values) / len(values) * 1e3, 4) if values else None


# --------------------------------------------------------------- processes

def _proc_table():
    """{pid: (ppid, pgid, state, starttime)} of every process."""
    table = {}
    for name in os.listdir('/proc'):
        if not name.isdigit():
            continue
        try:
            with open('/proc/%s/stat' % name) as f:
                stat = f.read()
        except OSError:
            continue
        fields = stat[stat.rfind(')') + 2:].split()
        table[int(name)] = (int(fields[1]), int(fields[2]), fields[0],
                            fields[19])
    return table


def _cmdline(pid):
    """The first words of a process's command line, for messages."""
    try:
        with open('/proc/%d/cmdline' % pid, 'rb') as f:
            argv = f.read().split(b'\0')
    except OSError:
        return '?'
    return ' '.join(os.path.basename(a.decode(errors='replace'))
                    for a in argv[:3])


def faketime_start(parent):
    """True time (s) the faketime child of ``parent`` started, from /proc
    (10 ms resolution), or None.  libfaketime's drift starts there."""
    for pid, (ppid, _, _, start) in _proc_table().items():
        if ppid == parent and _cmdline(pid).startswith('faketime'):
            since_boot = time.clock_gettime(time.CLOCK_BOOTTIME)
            return (time.time() - since_boot
                    + int(start) / os.sysconf('SC_CLK_TCK'))
    return None


class Processes:
    """Child processes, each in its own session, and their cleanup.

    The bench is a child subreaper, so descendants whose parent died stay
    in its tree; ``stop`` signals the process group of every live
    descendant (roslaunch puts each node in a group of its own).
    """

    def __init__(self, logdir, env):
        self.logdir = logdir
        self.env = env
        self.children = []      # (name, Popen)
        self.me = os.getpid()
        self.my_pgid = os.getpgid(0)
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(PR_SET_CHILD_SUBREAPER, 1, 0, 0, 0)
        except OSError:
            pass

    def start(self, name, argv):
        out = open(os.path.join(self.logdir, name + '.log'), 'w')
        proc = subprocess.Popen(argv, env=self.env, stdout=out,
                                stderr=subprocess.STDOUT,
                                stdin=subprocess.DEVNULL,
                                start_new_session=True)
        out.close()
        self.children.append((name, proc))
        return proc

    def descendants(self):
        """{pid: (pgid, starttime)} of the live descendants."""
        table = _proc_table()
        kids = {}
        for pid, (ppid, _, _, _) in table.items():
            kids.setdefault(ppid, []).append(pid)
        out, todo = {}, list(kids.get(self.me, []))
        while todo:
            pid = todo.pop()
            ppid, pgid, state, start = table[pid]
            if state not in ('Z', 'X'):
                out[pid] = (pgid, start)
            todo.extend(kids.get(pid, []))
        return out

    def _reap(self):
        for _, p in self.children:
            p.poll()
        while True:
            try:
                pid, _ = os.waitpid(-1, os.WNOHANG)
            except ChildProcessError:
                return
            if pid == 0:
                return

    def _signal_all(self, sig, targets):
        live = self.descendants()
        for pid, (pgid, start) in targets.items():
            if live.get(pid) != (pgid, start):
                continue  # gone (or the pid was reused)
            for kill, ident in ((os.killpg, pgid), (os.kill, pid)):
                if kill is os.killpg and pgid in (self.my_pgid, 0):
                    continue
                try:
                    kill(ident, sig)
                except (ProcessLookupError, PermissionError):
                    pass

    def _wait_gone(self, timeout):
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            self._reap()
            if not self.descendants():
                return True
            time.sleep(0.1)
        return not self.descendants()

    def stop(self, grace=6.0):
        """SIGINT the launchers (skewed_client kills its client 3 s
        later), then SIGTERM and SIGKILL what is left."""
        for _, p in reversed(self.children):
            if p.poll() is None:
                try:
                    os.killpg(p.pid, signal.SIGINT)
                except ProcessLookupError:
                    pass
        end = time.monotonic() + grace
        while time.monotonic() < end and any(
                p.poll() is None for _, p in self.children):
            time.sleep(0.1)
        for sig, wait in ((signal.SIGTERM, 3.0), (signal.SIGKILL, 2.0)):
            left = self.descendants()
            if not left:
                break
            log('%s to %d leftover processes: %s', sig.name, len(left),
                ', '.join('%d %s' % (pid, _cmdline(pid)) for pid in left))
            self._signal_all(sig, left)
            if self._wait_gone(wait):
                break
        left = self.descendants()
        if left:
            log('WARNING: processes survived cleanup: %s', sorted(left))
        self._reap()


# -------------------------------------------------------------- recording

class Recorder:
    """Arrival times (true clock) and states the RoundLog does not keep."""

    def __init__(self, clients):
        self.sync = {}          # round -> (arrival, SyncTime)
        self.ack_arrival = {}   # round -> {client: arrival}
        self.status = {}        # round -> [RoundStatus]
        self.decided_at = {}    # round -> arrival of the Decision
        self.clock_ok = {}      # client -> ClockState
        self.clock_states = {}  # client -> [(arrival, ClockState)]
        rospy.Subscriber('/sync_time', SyncTime, self._on_sync)
        rospy.Subscriber('/sync_ack', SyncAck, self._on_ack, queue_size=100)
        rospy.Subscriber('/round_status', RoundStatus, self._on_status,
                         queue_size=100)
        rospy.Subscriber('/decision', Decision, self._on_decision,
                         queue_size=100)
        for c in clients:
            rospy.Subscriber('/%s/clock_state' % c, ClockState,
                             self._on_clock, c)

    def _on_sync(self, msg):
        self.sync[msg.round] = (time.time(), msg)

    def _on_ack(self, msg):
        self.ack_arrival.setdefault(msg.round, {})[msg.client_id] = \
            time.time()

    def _on_status(self, msg):
        self.status.setdefault(msg.round, []).append(msg)

    def _on_decision(self, msg):
        self.decided_at.setdefault(msg.round, time.time())

    def _on_clock(self, msg, client):
        if msg.ok:
            self.clock_ok[client] = msg
            self.clock_states.setdefault(client, []).append(
                (time.time(), msg))


# --------------------------------------------------------------- analysis

def analyse_round(n, rec, log_round, clocks, failures):
    """Figures of round ``n``: a dict, and failure notes appended."""
    out = {'round': n}
    statuses = rec.status.get(n, [])
    aborted = [s for s in statuses if s.state == RoundStatus.ABORTED]
    decision = log_round['decision'] if log_round else None
    capture = log_round['capture'] if log_round else None
    if aborted:
        reason = aborted[-1].reason
        fail(failures, 'aborted', '%s', reason if reason.startswith(
            'round %d ' % n) else 'round %d aborted: %s' % (n, reason))
        out['aborted'] = aborted[-1].reason
    if log_round is None or n not in rec.sync:
        fail(failures, 'never_started',
             'round %d never started (no sync_time seen)', n)
        out['missing'] = True
        return out
    clients = sorted(clocks)
    acks = log_round['acks']
    for c in clients:
        if c not in acks:
            fail(failures, 'missing_ack', 'round %d: no ACK from %s', n, c)
        elif not acks[c].ok:
            fail(failures, 'nack', 'round %d: NACK from %s: %s', n, c,
                 acks[c].reason)
    arrivals = rec.ack_arrival.get(n, {})
    if all(c in arrivals for c in clients):
        out['ack_round'] = max(arrivals.values()) - rec.sync[n][0]
    out['ack_offset_error'] = []
    for c, a in acks.items():
        if c in clocks and a.ok and math.isfinite(a.offset):
            offset, rate, t0 = clocks[c]
            t = a.stamp.to_sec()
            injected = -(offset + (rate - 1.0) * (t - t0))
            out['ack_offset_error'].append(abs(a.offset - injected))
            out.setdefault('ack_offset_signed', {})[c] = a.offset - injected
    if decision is None:
        fail(failures, 'no_decision', 'round %d: no decision', n)
    elif decision.outcome == Decision.ABORTED and not aborted:
        fail(failures, 'aborted', 'round %d: decision aborted: %s', n,
             decision.reason)
    if capture is None:
        if not aborted:
            fail(failures, 'no_capture_data', 'round %d: no capture_data',
                 n)
        return out
    out['capture_order'] = (capture.cr_t.to_sec()
                            - rec.sync[n][1].stamp.to_sec())
    out['str_aft'] = capture.str_aft
    results = log_round['results']
    timings = []
    out['wake'], out['frames'] = [], []
    for c in capture.clients:
        r = results.get(c)
        if r is None:
            fail(failures, 'missing_result', 'round %d: no result from %s',
                 n, c)
        else:
            if r.status != ClientResult.OK:
                why = ['%d frames, coverage %.2f' % (r.frames, r.coverage)]
                why += ['%s=%s' % (kv.key, kv.value) for kv in r.diagnostics
                        if kv.key in ('reason', 'error')]
                fail(failures, 'result_' + r.status,
                     'round %d: %s result %s (%s)', n, c, r.status,
                     ', '.join(why))
            out['frames'].append(r.frames)
            if math.isfinite(r.wake_lateness):
                out['wake'].append(r.wake_lateness)
        t = client_timing(c, log_round['captured'].get(c, []))
        if not t.samples:
            fail(failures, 'no_samples',
                 'round %d: no captured samples from %s', n, c)
        timings.append(t)
    missing_clients = [c for c in clients if c not in capture.clients]
    if missing_clients:
        fail(failures, 'quorum', 'round %d: captured without %s (quorum)',
             n, ','.join(missing_clients))
    start = Capture.from_msg(capture).start
    out['model_errors'] = {}
    for c in capture.clients:
        states = [m for t, m in rec.clock_states.get(c, []) if t < start]
        if c in clocks and states:
            offset, rate, t0 = clocks[c]
            s = states[-1]
            local = start + offset + (rate - 1.0) * (start - t0)
            model = model_from_msg(s)
            out['model_errors'][c] = model.to_global(local) - start
    if len(out['model_errors']) >= 2:
        e = out['model_errors'].values()
        out['model_skew'] = max(e) - min(e)
    out['errors'] = {t.client_id: t.clock_error for t in timings
                     if math.isfinite(t.clock_error)}
    if len(out['errors']) == len(clients):
        out['skew'] = start_skew(timings)
        out['same_first'] = len({t.first_index for t in timings}) == 1
    return out


def summarize(args, rounds, failures, clocks, extra):
    """The JSON object of the run: ``extra`` merged into the figures."""
    skews = [r['skew'] for r in rounds if 'skew' in r]
    errors = [abs(e) for r in rounds for e in r.get('errors', {}).values()]
    signed = {c: [r['errors'][c] for r in rounds
                  if c in r.get('errors', {})] for c in clocks}
    return dict({
        'clients': args.clients,
        'rounds': args.rounds,
        'rounds_run': len(rounds),
        'ok': not failures,
        'start_skew_ms': ms(percentiles(skews)),
        'offset_error_ms': ms(percentiles(errors)),
        'clock_skew_ms': ms(percentiles(
            [r['model_skew'] for r in rounds if 'model_skew' in r])),
        'clock_model_error_ms': ms(percentiles(
            [abs(e) for r in rounds
             for e in r.get('model_errors', {}).values()])),
        'ack_round_ms': ms(percentiles(
            [r['ack_round'] for r in rounds if 'ack_round' in r])),
        'capture_order_ms': ms(percentiles(
            [r['capture_order'] for r in rounds if 'capture_order' in r])),
        'wake_lateness_ms': ms(percentiles(
            [w for r in rounds for w in r.get('wake', [])])),
        'ack_offset_error_ms': ms(percentiles(
            [e for r in rounds for e in r.get('ack_offset_error', [])])),
        'frames_per_window': {
            'expected': int(round(args.dur * args.rate)),
            'min': min((f for r in rounds for f in r.get('frames', [])),
                       default=None),
            'p50': median([f for r in rounds for f in r.get('frames', [])])},
        'str_aft_s': sorted({round(r['str_aft'], 3) for r in rounds
                             if 'str_aft' in r}),
        'rounds_measured': len(skews),
        'rounds_same_first_sample': sum(1 for r in rounds
                                        if r.get('same_first')),
        'start_skew_per_round_ms': [round(r['skew'] * 1e3, 3)
                                    if 'skew' in r else None
                                    for r in rounds],
        'clock_error_mean_ms': {c: mean_ms(v)
                                for c, v in sorted(signed.items())},
        'clocks': {c: {'offset_s': round(o, 6),
                       'drift_ppm': round((rate - 1) * 1e6, 3),
                       'ack_offset_error_mean_ms': mean_ms(
                           [r['ack_offset_signed'][c] for r in rounds
                            if c in r.get('ack_offset_signed', {})])}
                   for c, (o, rate, _) in sorted(clocks.items())},
        'failures': len(failures),
        'failure_counts': dict(Counter(k for k, _ in failures)),
        'failure_notes': [note for _, note in failures[:50]],
    }, **extra)


# ------------------------------------------------------------------- main

def add_args(p, rounds, max_offset_help):
    """The flags of both benches up to --ack-timeout (``rounds``: the
    default of --rounds)."""
    p.add_argument('--clients', type=int, default=2)
    p.add_argument('--rounds', type=int, default=rounds)
    p.add_argument('--dur', type=float, default=2.0,
                   help='capture window, s (default 2)')
    p.add_argument('--str-aft', default='auto',
                   help="STR_AFT in s, or 'auto' (default)")
    p.add_argument('--rate', type=float, default=100.0,
                   help='reference sensor rate, Hz (default 100)')
    p.add_argument('--max-offset', type=float, default=3.0,
                   help=max_offset_help)
    p.add_argument('--max-drift', type=float, default=200.0,
                   help='clock drifts within +/- this, ppm (default 200)')
    p.add_argument('--ack-timeout', type=float, default=3.0)


def add_run_args(p):
    """The last flags of both benches: --seed, --timeout, --keep-logs."""
    p.add_argument('--seed', type=int, default=None,
                   help='random seed of the clocks (default: random)')
    p.add_argument('--timeout', type=float, default=None,
                   help='bound on the run before cleanup, s (default: '
                   'from the rounds, the window and the clients)')
    p.add_argument('--keep-logs', action='store_true',
                   help='keep the processes\' logs even on success')


def check_args(p, args):
    """``p.error`` on a bad value of the flags of ``add_args``; a random
    --seed when none was given."""
    if args.clients < 1 or args.rounds < 1:
        p.error('--clients and --rounds must be >= 1')
    if not (args.dur > 0 and args.rate > 0):
        p.error('--dur and --rate must be > 0')
    if args.str_aft != 'auto':
        try:
            if float(args.str_aft) <= 0:
                raise ValueError
        except ValueError:
            p.error("--str-aft must be a number of seconds > 0 or 'auto'")
    if args.seed is None:
        args.seed = random.SystemRandom().randrange(1 << 31)


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    add_args(p, 20, 'clock offsets within +/- this, s (default 3)')
    add_run_args(p)
    args = p.parse_args()
    check_args(p, args)
    return args


def node(name):
    """The path of an executable of hri_sync (the catkin one first)."""
    path = roslib.packages.find_node('hri_sync', name)
    if not path:
        raise RuntimeError('node hri_sync/%s not found: build and source the '
                           'workspace first' % name)
    return path[0]


def wait_until(what, predicate, timeout, procs=()):
    """Poll until ``predicate()``; RuntimeError naming ``what`` otherwise
    (also when one of ``procs`` (name, Popen) exits early)."""
    end = time.monotonic() + timeout
    while True:
        if predicate():
            return
        for name, p in procs:
            if p.poll() is not None:
                raise RuntimeError('%s exited with status %s while waiting '
                                   'for %s' % (name, p.returncode, what))
        if time.monotonic() > end:
            raise RuntimeError('timed out after %.0f s waiting for %s'
                               % (timeout, what))
        time.sleep(0.1)


def clients_ready(master, clients, rec):
    """Every CPM listens to /sync_time and published a synced clock, and
    every DPM reads the reference."""
    try:
        _, subs, _ = master.getSystemState()
    except Exception:
        return False
    subs = dict((t, set(n)) for t, n in subs)
    return all('/%s/cpm' % c in subs.get('/sync_time', ())
               and '/%s/dpm' % c in subs.get('/reference/samples', ())
               and c in rec.clock_ok for c in clients)


def delivery_order(master, clients):
    """The clients in the order the reference sensor writes each sample
    to them (its connections, oldest first), from its getBusInfo."""
    try:
        api = ServerProxy(master.lookupNode('/reference'))
        _, _, bus = api.getBusInfo('/sync_skew_bench')
    except Exception as e:  # only a diagnostic: say why it is missing
        return 'unknown: %s' % e
    dpms = {'/%s/dpm' % c: c for c in clients}
    return [dpms[b[1]] for b in sorted(bus, key=lambda b: b[0])
            if b[2] == 'o' and b[4] == '/reference/samples'
            and b[1] in dpms]


def time_budget(args):
    """The bound on the whole run, s: --timeout or from the setup, the
    rounds and the window."""
    per_round = (args.ack_timeout + (float(args.str_aft)
                                     if args.str_aft != 'auto' else 2.0)
                 + args.dur + 7.0)
    return args.timeout or (SETUP_TIME + SETUP_PER_CLIENT * args.clients
                            + 20.0 + args.rounds * per_round)


def start_ros(procs, name, core_argv, master_uri, clients, state):
    """Start the roscore (``core_argv``), make this process the ROS node
    ``name`` recording the rounds (``state``: its Recorder and RoundLog);
    the master."""
    core = procs.start('roscore', core_argv)
    master = rosgraph.Master('/' + name, master_uri=master_uri)

    def master_up():
        try:
            master.getPid()
            return True
        except Exception:
            return False
    wait_until('the roscore at %s' % master_uri, master_up, 30,
               [('roscore', core)])
    os.environ['ROS_MASTER_URI'] = master_uri
    rospy.init_node(name, anonymous=True, disable_signals=True)
    state['rec'] = Recorder(clients)
    state['rlog'] = RoundLog(clients, 'hri_sync/Sample')
    return master


def start_time_server(procs, host, port, what, extra=(), wrap=list):
    """Start chronyd (``timeserver.launch`` with ``extra`` arguments, run
    by ``wrap(argv)``) and wait until it answers on ``host``:``port``.
    Required here: its roslaunch exits when chronyd dies, which the bench
    sees as a died process."""
    ts = procs.start('time_server', wrap([
        'roslaunch', '--wait', 'hri_sync', 'timeserver.launch',
        'ntp_port:=%d' % port, 'required:=true'] + list(extra)))

    def ntp_up():
        try:
            ntp.measure(host, port, 1, 0.2)
            return True
        except ntp.NtpError:
            return False
    wait_until(what, ntp_up, 30, [('time_server', ts)])
    return ts


def start_reference(procs, args, wrap=list):
    """Start the reference sensor on the true clock."""
    return procs.start('reference', wrap([
        node('synthetic_sensor'), '__name:=reference',
        '_rate:=%g' % args.rate, '_phase:=0.5', '_signal:=true_time']))


def random_clock(rng, args):
    """(offset s, rate, faketime spec) of a client, from ``rng``."""
    offset = rng.uniform(-args.max_offset, args.max_offset)
    rate = 1.0 + rng.uniform(-args.max_drift, args.max_drift) * 1e-6
    return offset, rate, '%+.6fs x%.9f' % (offset, rate)


def start_client(procs, client, launcher, ntp_args, wrap=list):
    """Start ``client.launch`` by ``launcher`` (its ``ntp_args``), its DPM
    reading the reference."""
    return procs.start(client, wrap(launcher + [
        'client.launch', 'client_id:=%s' % client] + ntp_args + [
        'input:=/reference/samples', 'stamp_source:=arrival']))


def wait_clients(master, clients, state, started, clocks, faked):
    """Wait until the clients are ready, then refer the injected clock of
    each client in ``faked`` to its faketime process's start."""
    wait_until('%d clients (CPM synced, DPM reading the reference)'
               % len(clients),
               lambda: clients_ready(master, clients, state['rec']),
               SETUP_TIME + SETUP_PER_CLIENT * len(clients), started)
    for name, p in started:
        if name in faked:
            t0 = faketime_start(p.pid)
            if t0 is None:
                log('WARNING: no faketime process of %s found: the injected'
                    ' offset is referred to its launch time', name)
            else:
                clocks[name] = clocks[name][:2] + (t0,)


def start_server(procs, args, clients, started, ntp_args, wrap=list):
    """Start the server for the rounds (its ``ntp_args``); the process,
    also appended to ``started``."""
    log('%d clients ready; starting the server for %d rounds (dur %g s, '
        'str_aft %s)', len(clients), args.rounds, args.dur, args.str_aft)
    server = procs.start('server', wrap([
        'roslaunch', '--wait', 'hri_sync', 'server.launch',
        'clients:=%s' % ','.join(clients), 'rounds:=%d' % args.rounds,
        'dur:=%g' % args.dur, 'str_aft:=%s' % args.str_aft,
        'ack_timeout:=%g' % args.ack_timeout] + ntp_args))
    started.append(('server', server))
    return server


def record_rounds(args, state, clocks, started, result, deadline,
                  wake=True):
    """Log each round once decided, until all are, the server has been
    gone 3 s or ``deadline`` (monotonic) passed; note in ``result`` the
    processes that died (``wake``: log the wake lateness too)."""
    rec, rlog = state['rec'], state['rlog']
    server = dict(started)['server']
    reported, server_done = set(), None
    while True:
        now = time.monotonic()
        if now > deadline:
            result['timed_out'] = True
            log('run-time bound of %.0f s reached', result['timeout_s'])
            break
        for name, p in started:
            if name != 'server' and p.poll() is not None \
                    and name not in result['died']:
                result['died'][name] = p.returncode
                log('ERROR: %s exited with status %s', name, p.returncode)
        if server.poll() is not None and server_done is None:
            server_done = now
            log('server exited (status %s)', server.returncode)
        for n, t in sorted(rec.decided_at.items()):
            if n in reported or time.time() - t < 0.7:
                continue
            rlog.assign_captured()
            with rlog.lock:
                lr = rlog.rounds.get(n)
            notes = []
            r = analyse_round(n, rec, lr, clocks, notes)
            reported.add(n)
            log('round %d: ack %s ms, str_aft %s, start skew %s ms, clock '
                'errors [%s] ms%s%s', n,
                '%.1f' % (r['ack_round'] * 1e3) if 'ack_round' in r else '-',
                '%.3f' % r['str_aft'] if 'str_aft' in r else '-',
                '%.3f' % (r['skew'] * 1e3) if 'skew' in r else '-',
                ' '.join('%s %+.3f' % (c, e * 1e3)
                         for c, e in sorted(r.get('errors', {}).items())),
                ', wake %s ms' % '/'.join('%.1f' % (w * 1e3)
                                          for w in r.get('wake', []))
                if wake else '',
                ''.join('\n    ' + x for _, x in notes))
        if all(n in reported for n in range(1, args.rounds + 1)):
            break
        if server_done is not None and now - server_done > 3.0:
            break
        time.sleep(0.2)
    time.sleep(0.5)


def run(args, procs, env, ntp_port, clocks, result, state):
    """Start everything and record the rounds (``state``: the bench's
    Recorder and RoundLog)."""
    clients = ['c%d' % (i + 1) for i in range(args.clients)]
    deadline = time.monotonic() + result['timeout_s']
    rng = random.Random(args.seed)

    master_uri = env['ROS_MASTER_URI']
    master = start_ros(procs, 'sync_skew_bench',
                       ['roscore', '-p', master_uri.split(':')[-1]],
                       master_uri, clients, state)
    ntp_args = ['ntp_port:=%d' % ntp_port]
    ts = start_time_server(procs, '127.0.0.1', ntp_port,
                           'chronyd on NTP port %d' % ntp_port)
    log('roscore %s, chronyd on 127.0.0.1:%d', master_uri, ntp_port)

    started = [('time_server', ts),
               ('reference', start_reference(procs, args))]
    for c in clients:
        offset, rate, spec = random_clock(rng, args)
        clocks[c] = (offset, rate, time.time())
        log('client %s: faketime %r', c, spec)
        started.append((c, start_client(
            procs, c, [node('skewed_client'), '--clock', spec], ntp_args)))
    wait_clients(master, clients, state, started, clocks, clients)
    result['reference_delivery_order'] = delivery_order(master, clients)
    start_server(procs, args, clients, started, ntp_args)
    record_rounds(args, state, clocks, started, result, deadline)


def analyse(args, state, clocks, result):
    """(per-round figures, failure notes) of what was recorded."""
    rec, rlog = state.get('rec'), state.get('rlog')
    final, failures, missing = [], [], []
    if rec is not None:
        rlog.assign_captured()
        for n in range(1, args.rounds + 1):
            with rlog.lock:
                lr = rlog.rounds.get(n)
            if n not in rec.sync and n not in rec.status:
                missing.append(n)
                continue
            final.append(analyse_round(n, rec, lr, clocks, failures))
    if missing:
        fail(failures, 'never_started', '%d rounds never started: %s',
             len(missing), ','.join(map(str, missing)))
    for name, code in result['died'].items():
        fail(failures, 'process_died', '%s exited early with status %s',
             name, code)
    if result.get('timed_out'):
        fail(failures, 'timed_out', 'run-time bound of %.0f s reached',
             result['timeout_s'])
    return final, failures


def bench_main(args, started, logdir, result, clocks, run, stop,
               more=lambda state: {}):
    """Run ``run(state)`` under the signal handlers and the hard bound,
    then ``stop()`` whatever happened; print the JSON of what ``state``
    recorded (plus ``more(state)``, the bench's own keys) and exit with
    the status.  ``started``: monotonic start of the bench."""
    def on_signal(signum, _frame):
        raise Interrupted(signal.Signals(signum).name)
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP,
                signal.SIGALRM):
        signal.signal(sig, on_signal)
    log('N=%d R=%d seed %d; logs in %s', args.clients, args.rounds,
        args.seed, logdir)
    load = os.getloadavg()
    failures, status, state = [], 0, {}
    try:
        # Hard bound, should the orderly one in run() not be reached.
        signal.alarm(int(result['timeout_s']) + 30)
        run(state)
    except Interrupted as e:
        fail(failures, 'interrupted', 'interrupted by %s', e)
        log('interrupted (%s): cleaning up', e)
        status = 130
    except RuntimeError as e:
        fail(failures, 'setup_failed', 'setup failed: %s', e)
        log('ERROR: setup failed: %s', e)
        status = 2
    except Exception as e:  # a bench bug: still clean up and report it
        fail(failures, 'error', 'bench error: %r', e)
        log('ERROR: %r', e)
        status = 2
    finally:
        signal.alarm(0)
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
            signal.signal(sig, lambda *_: log('cleaning up, please wait'))
        if not rospy.core.is_shutdown():
            rospy.signal_shutdown('benchmark done')
        stop()
    final, notes = analyse(args, state, clocks, result)
    failures = notes + failures
    if status == 0 and failures:
        status = 1
    result.pop('died')
    out = summarize(args, final, failures, clocks, dict(
        result, dur_s=args.dur, rate_hz=args.rate, seed=args.seed,
        **more(state), elapsed_s=round(time.monotonic() - started, 1),
        loadavg_1min=[round(load[0], 2), round(os.getloadavg()[0], 2)]))
    if status == 0 and not args.keep_logs:
        shutil.rmtree(logdir, ignore_errors=True)
    else:
        out['logs'] = logdir
    for _, note in failures:
        log('FAILURE: %s', note)
    log('start skew p99 %s ms, offset error p99 %s ms over %d rounds',
        out['start_skew_ms']['p99'], out['offset_error_ms']['p99'],
        out['rounds_measured'])
    print(json.dumps(out, allow_nan=False), flush=True)
    sys.exit(status)


def main():
    args = parse_args()
    started = time.monotonic()
    logdir = tempfile.mkdtemp(prefix='hri_sync_bench_')
    master_uri = 'http://127.0.0.1:%d' % free_port(socket.SOCK_STREAM)
    ntp_port = free_port(socket.SOCK_DGRAM)
    env = dict(os.environ, ROS_MASTER_URI=master_uri, ROS_LOG_DIR=logdir,
               ROS_HOME=logdir, PYTHONUNBUFFERED='1')
    env.pop('ROS_IP', None)
    env['ROS_HOSTNAME'] = 'localhost'
    os.environ['ROS_LOG_DIR'] = logdir
    os.environ['ROS_HOSTNAME'] = 'localhost'
    procs = Processes(logdir, env)
    clocks = {}
    result = {'died': {}, 'timeout_s': round(time_budget(args), 1)}
    bench_main(args, started, logdir, result, clocks,
               lambda state: run(args, procs, env, ntp_port, clocks,
                                 result, state),
               procs.stop)


if __name__ == '__main__':
    main()
