"""The start-skew benches on ROS: the stack they start and the rounds.

``bench/sync_skew.py`` (one host) and ``bench/multihost.py`` (network
namespaces) are this with different command wrappers: a ``SkewBench``
starts, as ``harness.Processes``, a roscore, chronyd, the sensors on the
true clock, N clients (under ``skewed_client`` with a ``FakeClock`` each)
and the server, makes the bench process a ROS node on the true clock that
records every round, and prints the JSON of ``tools.skew_figures``.

Two sensor setups (``--sensors``): ``shared``, one reference publisher
feeding every client (the sample is written to its N subscribers one after
the other, so the k-th client in line gets it later), and ``own``, one
sensor per client as at a real site.  The DPMs stamp at arrival or map the
sensor's device stamp (``--stamp-source``).
"""
import json
import os
import random
import shutil
import socket
import sys
import tempfile
import time
from xmlrpc.client import ServerProxy

import rosgraph
import rospy

from hri_sync.msg import ClockState, Decision, RoundStatus, SyncAck, SyncTime
from hri_sync.ros.round_log import RoundLog
from hri_sync.clock import ntp
from hri_sync_support import harness
from hri_sync_support.skew_figures import analyse_round, fail, summarize

SETUP_TIME = 30.0        # s for roscore, chronyd and the sensors
SETUP_PER_CLIENT = 6.0   # s more per client
HARD_BOUND_MARGIN = 30.0  # s after the run's bound: SIGALRM
DEVICE_PROCESSOR = 'hri_sync.data_process.processors.DeviceStampedCountMean'


# ------------------------------------------------------------------- flags

def add_args(p, rounds, max_offset_help):
    """The flags of both benches up to --warmup (``rounds``: the
    default of --rounds)."""
    p.add_argument('--clients', type=int, default=2)
    p.add_argument('--rounds', type=int, default=rounds)
    p.add_argument('--dur', type=float, default=2.0,
                   help='capture window, s (default 2)')
    p.add_argument('--str-aft', default='auto',
                   help="STR_AFT in s, or 'auto' (default)")
    p.add_argument('--rate', type=float, default=100.0,
                   help='sensor rate, Hz (default 100)')
    p.add_argument('--max-offset', type=float, default=3.0,
                   help=max_offset_help)
    p.add_argument('--max-drift', type=float, default=200.0,
                   help='clock drifts within +/- this, ppm (default 200)')
    p.add_argument('--ack-timeout', type=float, default=3.0)
    p.add_argument('--sensors', choices=('shared', 'own'), default='shared',
                   help="'shared' (default): one reference sensor publishes "
                   "to every client; 'own': one sensor per client")
    p.add_argument('--sensor-phase', choices=('spread', 'same'),
                   default='spread',
                   help="with --sensors own: the sensors' phases spread "
                   "over the period (default) or all the same")
    p.add_argument('--stamp-source', choices=('arrival', 'device'),
                   default='arrival',
                   help="the DPMs stamp samples at arrival (default) or "
                   "map the sensor's device stamp (header.stamp)")
    p.add_argument('--warmup', type=float, default=0.0,
                   help='s from the clients being ready to the first '
                   'round (default 0), e.g. to let device clock maps fill '
                   'their window')


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
    if not args.warmup >= 0:
        p.error('--warmup must be >= 0')
    if args.str_aft != 'auto':
        try:
            if float(args.str_aft) <= 0:
                raise ValueError
        except ValueError:
            p.error("--str-aft must be a number of seconds > 0 or 'auto'")
    if args.seed is None:
        args.seed = random.SystemRandom().randrange(1 << 31)


def local_env(prefix, pythonpath=None):
    """A bench on this host with a master of its own: (logdir, the
    environment of the processes it starts, a free NTP port).  This
    process's ROS_LOG_DIR and ROS_HOSTNAME follow; ``pythonpath``: the
    children's PYTHONPATH entries, or inherited."""
    logdir = tempfile.mkdtemp(prefix=prefix)
    master_uri = 'http://127.0.0.1:%d' % harness.free_port(socket.SOCK_STREAM)
    env = dict(os.environ, ROS_MASTER_URI=master_uri, ROS_LOG_DIR=logdir,
               ROS_HOME=logdir, PYTHONUNBUFFERED='1', ROS_HOSTNAME='localhost')
    if pythonpath is not None:
        env['PYTHONPATH'] = os.pathsep.join(pythonpath)
    env.pop('ROS_IP', None)
    os.environ['ROS_LOG_DIR'] = logdir
    os.environ['ROS_HOSTNAME'] = 'localhost'
    return logdir, env, harness.free_port(socket.SOCK_DGRAM)


def time_budget(args):
    """The bound on the whole run, s: --timeout or from the setup, the
    rounds and the window."""
    per_round = (args.ack_timeout + (float(args.str_aft)
                                     if args.str_aft != 'auto' else 2.0)
                 + args.dur + 7.0)
    return args.timeout or (SETUP_TIME + SETUP_PER_CLIENT * args.clients
                            + 20.0 + args.warmup + args.rounds * per_round)


# --------------------------------------------------------------- recording

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


# ------------------------------------------------------------------- bench

def no_wrap(argv):
    """The command as it is (one host)."""
    return list(argv)


class SkewBench:
    """One run: its processes, clients, clocks, recording and result.

    ``wrap(host)`` gives the command wrapper of a host ('server' or a
    client): what runs a command there (``no_wrap`` on one host).
    """

    def __init__(self, name, args, procs, log, timeout, wrap=None):
        self.name = name
        self.args = args
        self.procs = procs
        self.log = log
        self.wrap = wrap or (lambda host: no_wrap)
        self.clients = ['c%d' % (i + 1) for i in range(args.clients)]
        self.clocks = {}        # client -> harness.FakeClock
        self.inputs = {}        # client -> the sensor topic its DPM reads
        self.started = []       # (name, Popen) that must keep running
        self.died = {}          # name -> exit status
        self.result = {'timeout_s': round(timeout, 1)}
        self.rec = self.rlog = self.master = None

    @property
    def same_sensor(self):
        return self.args.sensors == 'shared'

    def start_ros(self, core_argv, master_uri):
        """Start the roscore (``core_argv``) and make this process the ROS
        node recording the rounds."""
        core = self.procs.start('roscore', core_argv)
        master = rosgraph.Master('/' + self.name, master_uri=master_uri)
        harness.wait_for_master(master_uri, 30, [('roscore', core)])
        os.environ['ROS_MASTER_URI'] = master_uri
        rospy.init_node(self.name, anonymous=True, disable_signals=True)
        self.rec = Recorder(self.clients)
        self.rlog = RoundLog(self.clients, 'hri_sync/Sample')
        self.master = master

    def start_time_server(self, host, port, extra=()):
        """Start chronyd (``timeserver.launch`` with ``extra`` arguments)
        on the server and wait until it answers on ``host``:``port``.
        Required here: its roslaunch exits when chronyd dies, which the
        bench sees as a died process."""
        ts = self.procs.start('time_server', self.wrap('server')([
            'roslaunch', '--wait', 'hri_sync', 'timeserver.launch',
            'ntp_port:=%d' % port, 'required:=true'] + list(extra)))

        def ntp_up():
            try:
                ntp.measure(host, port, 1, 0.2)
                return True
            except ntp.NtpError:
                return False
        harness.wait_until('chronyd on %s:%d' % (host, port), ntp_up, 30,
                           [('time_server', ts)])
        self.started.append(('time_server', ts))

    def start_sensors(self):
        """The sensors on the true clock: one reference on the server for
        every client (``shared``), or one per client on its host
        (``own``).  Their setup goes into the result."""
        node = harness.node_path('synthetic_sensor')
        n = len(self.clients)
        if self.same_sensor:
            self.started.append(('reference', self.procs.start(
                'reference', self.wrap('server')(harness.sensor_argv(
                    node, 'reference', self.args.rate, 0.5)))))
            self.inputs = {c: '/reference/samples' for c in self.clients}
            phases = [0.5]
        else:
            phases = [0.5 if self.args.sensor_phase == 'same'
                      else (0.5 + k / n) % 1.0 for k in range(n)]
            for c, phase in zip(self.clients, phases):
                name = 'sensor_' + c
                self.started.append((name, self.procs.start(
                    name, self.wrap(c)(harness.sensor_argv(
                        node, name, self.args.rate, phase)))))
                self.inputs[c] = '/%s/samples' % name
        self.result['setup'] = {
            'sensors': self.args.sensors,
            'publishers': len(phases),
            'clients_per_publisher': n if self.same_sensor else 1,
            'stamp_source': self.args.stamp_source,
            'sensor_phases': [round(p, 4) for p in phases],
            'warmup_s': self.args.warmup}

    def start_client(self, client, ntp_args):
        """Start ``client.launch`` of ``client`` (under ``skewed_client``
        with a FakeClock, or on the true clock when it has TRUE_CLOCK's
        offset and rate), its DPM reading its sensor."""
        clock = self.clocks[client]
        if (clock.offset, clock.rate) == (0.0, 1.0):
            launcher = ['roslaunch', '--wait', 'hri_sync']
        else:
            launcher = [harness.node_path('skewed_client'), '--clock',
                        clock.spec]
        dpm = ['input:=%s' % self.inputs[client],
               'stamp_source:=%s' % self.args.stamp_source]
        if self.args.stamp_source == 'device':
            dpm.append('processor:=%s' % DEVICE_PROCESSOR)
        self.started.append((client, self.procs.start(
            client, self.wrap(client)(launcher + [
                'client.launch', 'client_id:=%s' % client]
                + list(ntp_args) + dpm))))

    def _clients_ready(self):
        """Every CPM listens to /sync_time and published a synced clock,
        and every DPM reads its sensor."""
        try:
            _, subs, _ = self.master.getSystemState()
        except Exception:
            return False
        subs = dict((t, set(n)) for t, n in subs)
        return all('/%s/cpm' % c in subs.get('/sync_time', ())
                   and '/%s/dpm' % c in subs.get(self.inputs[c], ())
                   and c in self.rec.clock_ok for c in self.clients)

    def wait_clients(self):
        """Wait until the clients are ready, then refer the FakeClock of
        each faked client to a reading of its clock (faketime_reading;
        its faketime process's start when it cannot be read)."""
        harness.wait_until(
            '%d clients (CPM synced, DPM reading its sensor)'
            % len(self.clients), self._clients_ready,
            SETUP_TIME + SETUP_PER_CLIENT * len(self.clients), self.started)
        for name, p in self.started:
            if name in self.clocks and self.clocks[name].rate != 1.0:
                reading = harness.faketime_reading(p.pid)
                if reading is not None:
                    self.clocks[name] = self.clocks[name].through(*reading)
                    continue
                t0 = harness.faketime_start(p.pid)
                if t0 is None:
                    self.log('WARNING: no faketime process of %s found: the'
                             ' injected offset is referred to its launch '
                             'time', name)
                else:
                    self.log('WARNING: %s\'s clock could not be read: its'
                             ' drift is referred to its faketime\'s start',
                             name)
                    self.clocks[name] = self.clocks[name].started(t0)
        if self.same_sensor:
            self.result['reference_delivery_order'] = self._delivery_order()

    def _delivery_order(self):
        """The clients in the order the reference sensor writes each
        sample to them (its connections, oldest first), from its
        getBusInfo."""
        try:
            api = ServerProxy(self.master.lookupNode('/reference'))
            _, _, bus = api.getBusInfo('/' + self.name)
        except Exception as e:  # only a diagnostic: say why it is missing
            return 'unknown: %s' % e
        dpms = {'/%s/dpm' % c: c for c in self.clients}
        return [dpms[b[1]] for b in sorted(bus, key=lambda b: b[0])
                if b[2] == 'o' and b[4] == '/reference/samples'
                and b[1] in dpms]

    def start_server(self, ntp_args):
        """Start the server (control and decision modules) for the
        rounds."""
        a = self.args
        if a.warmup > 0:
            self.log('%d clients ready; warming up for %g s', len(
                self.clients), a.warmup)
            time.sleep(a.warmup)
        self.log('%d clients ready; starting the server for %d rounds (dur '
                 '%g s, str_aft %s)', len(self.clients), a.rounds, a.dur,
                 a.str_aft)
        self.started.append(('server', self.procs.start(
            'server', self.wrap('server')([
                'roslaunch', '--wait', 'hri_sync', 'server.launch',
                'clients:=%s' % ','.join(self.clients),
                'rounds:=%d' % a.rounds, 'dur:=%g' % a.dur,
                'str_aft:=%s' % a.str_aft,
                'ack_timeout:=%g' % a.ack_timeout] + list(ntp_args)))))

    def record_rounds(self, deadline, wake=True):
        """Log each round once decided, until all are, the server has been
        gone 3 s or ``deadline`` (monotonic) passed; note the processes
        that died (``wake``: log the wake lateness too)."""
        rec, rlog = self.rec, self.rlog
        server = dict(self.started)['server']
        reported, server_done = set(), None
        while True:
            now = time.monotonic()
            if now > deadline:
                self.result['timed_out'] = True
                self.log('run-time bound of %.0f s reached',
                         self.result['timeout_s'])
                break
            for name, p in self.started:
                if name != 'server' and p.poll() is not None \
                        and name not in self.died:
                    self.died[name] = p.returncode
                    self.log('ERROR: %s exited with status %s', name,
                             p.returncode)
            if server.poll() is not None and server_done is None:
                server_done = now
                self.log('server exited (status %s)', server.returncode)
            for n, t in sorted(rec.decided_at.items()):
                if n in reported or time.time() - t < 0.7:
                    continue
                rlog.assign_captured()
                with rlog.lock:
                    lr = rlog.rounds.get(n)
                notes = []
                r = analyse_round(n, rec, lr, self.clocks, notes,
                                  self.same_sensor)
                reported.add(n)
                self._log_round(n, r, notes, wake)
            if all(n in reported for n in range(1, self.args.rounds + 1)):
                break
            if server_done is not None and now - server_done > 3.0:
                break
            time.sleep(0.2)
        time.sleep(0.5)

    def _log_round(self, n, r, notes, wake):
        self.log(
            'round %d: ack %s ms, str_aft %s, start skew %s ms, clock '
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

    def analyse(self):
        """(per-round figures, failure notes) of what was recorded."""
        final, failures, missing = [], [], []
        if self.rec is not None:
            self.rlog.assign_captured()
            for n in range(1, self.args.rounds + 1):
                with self.rlog.lock:
                    lr = self.rlog.rounds.get(n)
                if n not in self.rec.sync and n not in self.rec.status:
                    missing.append(n)
                    continue
                final.append(analyse_round(n, self.rec, lr, self.clocks,
                                           failures, self.same_sensor))
        if missing:
            fail(failures, 'never_started', '%d rounds never started: %s',
                 len(missing), ','.join(map(str, missing)))
        for name, code in self.died.items():
            fail(failures, 'process_died', '%s exited early with status %s',
                 name, code)
        if self.result.get('timed_out'):
            fail(failures, 'timed_out', 'run-time bound of %.0f s reached',
                 self.result['timeout_s'])
        return final, failures

    def main(self, run, stop, logdir, started, more=lambda: {}):
        """Run ``run()`` under the signal handlers and the hard bound, then
        ``stop()`` whatever happened; print the JSON of what was recorded
        (plus ``more()``, the bench's own keys) and exit with the status:
        0 all rounds OK, 1 a failure, 2 setup failed, 130 interrupted.
        ``started``: monotonic start of the bench."""
        args = self.args
        self.log('N=%d R=%d seed %d; logs in %s', args.clients, args.rounds,
                 args.seed, logdir)
        load = os.getloadavg()

        def stop_all():
            if not rospy.core.is_shutdown():
                rospy.signal_shutdown('benchmark done')
            stop()
        status, run_failures = harness.run_bounded(
            run, stop_all, self.result['timeout_s'] + HARD_BOUND_MARGIN,
            self.log)
        final, notes = self.analyse()
        failures = notes + run_failures
        if status == 0 and failures:
            status = 1
        out = summarize(args, final, failures, self.clocks, dict(
            self.result, dur_s=args.dur, rate_hz=args.rate, seed=args.seed,
            **more(), elapsed_s=round(time.monotonic() - started, 1),
            loadavg_1min=[round(load[0], 2), round(os.getloadavg()[0], 2)]),
            self.same_sensor)
        if status == 0 and not args.keep_logs:
            shutil.rmtree(logdir, ignore_errors=True)
        else:
            out['logs'] = logdir
        for _, note in failures:
            self.log('FAILURE: %s', note)
        self.log('start skew p99 %s ms, offset error p99 %s ms over %d '
                 'rounds', out['start_skew_ms']['p99'],
                 out['offset_error_ms']['p99'], out['rounds_measured'])
        print(json.dumps(out, allow_nan=False), flush=True)
        sys.exit(status)
