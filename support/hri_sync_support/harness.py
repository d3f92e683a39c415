"""The harness the benches and test checkers share (not installed).

Contract: no rospy.  Process groups and their clean shutdown (``Processes``:
children each in a session of their own, the caller a child subreaper, every
live descendant found by walking /proc (``hri_sync.tools.procs``) and
stopped SIGINT -> SIGTERM -> SIGKILL); faketime clients (``FakeClock``: the
injected offset and drift of a libfaketime clock, its spec, its start read
from /proc); the true-clock reference (the command line of a
``synthetic_sensor`` whose samples carry their true send time); and what
every bench needs around them: free ports, polled waits that name what
they waited for, and a run under a time bound that always cleans up
(``run_bounded``).
"""
import contextlib
import io
import math
import os
import runpy
import signal
import socket
import subprocess
import sys
import time
from dataclasses import dataclass, replace

from hri_sync.tools.procs import (become_subreaper, cmdline, descendants,
                                  proc_table, reap, signal_each)


def _log_nowhere(fmt, *args):
    pass


class Processes:
    """Child processes, each in its own session, and their cleanup.

    This process becomes a child subreaper, so descendants whose parent
    died stay in its tree; ``stop`` signals the process group of every
    live descendant (roslaunch puts each node in a group of its own).
    ``log(fmt, *args)`` reports what cleanup had to do.
    """

    def __init__(self, logdir, env, log=_log_nowhere):
        self.logdir = logdir
        self.env = env
        self.log = log
        self.children = []      # (name, Popen)
        self.me = os.getpid()
        self.my_pgid = os.getpgid(0)
        become_subreaper()

    def start(self, name, argv):
        """Start ``argv`` in a new session, output to LOGDIR/name.log."""
        with open(os.path.join(self.logdir, name + '.log'), 'w') as out:
            proc = subprocess.Popen(argv, env=self.env, stdout=out,
                                    stderr=subprocess.STDOUT,
                                    stdin=subprocess.DEVNULL,
                                    start_new_session=True)
        self.children.append((name, proc))
        return proc

    def descendants(self):
        """{pid: ProcInfo} of the live descendants."""
        return descendants(self.me)

    def _reap(self):
        reap([p for _, p in self.children])

    def _signal_all(self, sig, targets):
        live = self.descendants()
        for pid, info in targets.items():
            now = live.get(pid)
            if now is None or (now.pgid, now.start) != (info.pgid,
                                                        info.start):
                continue  # gone (or the pid was reused)
            if info.pgid not in (self.my_pgid, 0):
                try:
                    os.killpg(info.pgid, sig)
                except (ProcessLookupError, PermissionError):
                    pass
            signal_each([pid], sig)

    def _wait_gone(self, timeout):
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            self._reap()
            if not self.descendants():
                return True
            time.sleep(0.1)
        return not self.descendants()

    def stop(self, grace=6.0):
        """SIGINT the launchers (``skewed_client`` kills its client 3 s
        later), then SIGTERM and SIGKILL what is left.  Returns the pids
        that survived (none, normally)."""
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
            self.log('%s to %d leftover processes: %s', sig.name, len(left),
                     ', '.join('%d %s' % (pid, cmdline(pid))
                               for pid in left))
            self._signal_all(sig, left)
            if self._wait_gone(wait):
                break
        left = sorted(self.descendants())
        if left:
            self.log('WARNING: processes survived cleanup: %s', left)
        self._reap()
        return left


# -------------------------------------------------------- faketime clients

@dataclass(frozen=True)
class FakeClock:
    """A libfaketime clock ``faketime -f '+OFFSETs xRATE'``: at true time t
    it reads t + offset + (rate - 1) (t - t0), t0 the true time the
    faketime process started (libfaketime's drift starts there)."""

    offset: float   # s
    rate: float     # 1 + drift
    t0: float       # true time, s

    @property
    def spec(self):
        """The ``faketime -f`` argument."""
        return '%+.6fs x%.9f' % (self.offset, self.rate)

    @property
    def drift_ppm(self):
        return (self.rate - 1.0) * 1e6

    def local(self, true):
        """The faked (local) clock's reading at true time ``true``."""
        return true + self.offset + (self.rate - 1.0) * (true - self.t0)

    def offset_at(self, true):
        """Global minus local at true time ``true``, for a global clock
        that is the true clock: what a client's ACK offset should be."""
        return true - self.local(true)

    def started(self, t0):
        """The same clock, its drift referred to ``t0``."""
        return replace(self, t0=t0)

    def through(self, true, local):
        """The same clock, its drift referred to the instant it read
        ``local`` at true time ``true`` (a reading of the clock itself)."""
        if self.rate == 1.0:
            return self
        return self.started(true - (local - true - self.offset)
                            / (self.rate - 1.0))


TRUE_CLOCK = FakeClock(0.0, 1.0, 0.0)


def random_clock(rng, max_offset, max_drift_ppm, t0):
    """A FakeClock with an offset within +/- ``max_offset`` s and a drift
    within +/- ``max_drift_ppm``, drawn from ``rng`` (offset first)."""
    offset = rng.uniform(-max_offset, max_offset)
    rate = 1.0 + rng.uniform(-max_drift_ppm, max_drift_ppm) * 1e-6
    return FakeClock(offset, rate, t0)


def start_time(info):
    """True time (s) a process started, from its ProcInfo (10 ms
    resolution: the kernel counts clock ticks after boot)."""
    since_boot = time.clock_gettime(time.CLOCK_BOOTTIME)
    return (time.time() - since_boot
            + info.start / os.sysconf('SC_CLK_TCK'))


def _faketime_child(parent, table):
    """The pid of the ``faketime`` child of ``parent`` in ``table`` (a
    proc_table), or None."""
    for pid, info in table.items():
        if info.ppid == parent and cmdline(pid).startswith('faketime'):
            return pid
    return None


def faketime_start(parent):
    """True time (s) the ``faketime`` child of ``parent`` started, or None
    when it has none (see ``start_time``)."""
    table = proc_table()
    pid = _faketime_child(parent, table)
    return start_time(table[pid]) if pid is not None else None


# Reads the true CLOCK_REALTIME (hri_sync.clock.truth: a raw syscall, which
# libfaketime does not see) around the faked one, 20 times; prints the
# tightest pair.
_CLOCK_PROBE = """
import time
from hri_sync.clock.truth import true_time
pairs = []
for _ in range(20):
    a = true_time(); faked = time.time(); b = true_time()
    pairs.append((b - a, (a + b) / 2, faked))
_, t, faked = min(pairs)
print('%.9f %.9f' % (t, faked))
"""


def faketime_reading(parent):
    """(true, faked) CLOCK_REALTIME read at one instant (within a few us)
    on the clock of the ``faketime`` child of ``parent``: a probe joins
    that faketime's clock (its environment: the preload and the shared
    memory that holds the clock's start), or None when there is no such
    process. The start time of the faketime process (``faketime_start``)
    is only the drift's start within the time libfaketime takes to start
    up, hundreds of ms on a loaded host: ~0.04 ms of error at 200 ppm."""
    table = proc_table()
    fake = _faketime_child(parent, table)
    under = [pid for pid, info in table.items()
             if fake is not None and info.ppid == fake]
    if not under:
        return None
    # The probe imports hri_sync as this process does.
    env = dict(os.environ, PYTHONPATH=os.pathsep.join(p for p in sys.path
                                                      if p))
    try:
        with open('/proc/%d/environ' % under[0], 'rb') as f:
            for item in f.read().split(b'\0'):
                key, _, value = item.decode(errors='replace').partition('=')
                if key.startswith('FAKETIME') or key == 'LD_PRELOAD':
                    env[key] = value
    except OSError:
        return None
    if 'FAKETIME_SHARED' not in env:
        return None
    out = subprocess.run([sys.executable, '-c', _CLOCK_PROBE], env=env,
                         capture_output=True, text=True, timeout=30)
    if out.returncode != 0:
        return None
    true, faked = map(float, out.stdout.split())
    return (true, faked) if math.isfinite(true) else None


# ------------------------------------------------ the true-clock reference

def sensor_argv(node, name, rate, phase):
    """Command of a ``synthetic_sensor`` (executable ``node``) named
    ``name`` on the true clock: each sample's ``value`` and
    ``header.stamp`` are its true send time, ``rate`` Hz at ``phase`` of
    the period; it publishes ``/NAME/samples``."""
    return [node, '__name:=%s' % name, '_rate:=%g' % rate,
            '_phase:=%g' % phase, '_signal:=true_time']


def node_path(name, package='hri_sync'):
    """The path of an executable of ``package`` (the catkin one first);
    RuntimeError when the workspace is not built and sourced."""
    import roslib.packages  # the catkin index; not needed by the rest
    path = roslib.packages.find_node(package, name)
    if not path:
        raise RuntimeError('node %s/%s not found: build and source the '
                           'workspace first' % (package, name))
    return path[0]


# ----------------------------------------------------------- around a run

def free_port(kind=socket.SOCK_STREAM, host='127.0.0.1'):
    """A free port chosen by the kernel (random ephemeral), TCP or UDP."""
    with socket.socket(socket.AF_INET, kind) as s:
        s.bind((host, 0))
        return s.getsockname()[1]


def wait_until(what, predicate, timeout, procs=(), poll=0.1):
    """Poll until ``predicate()`` is true and return its value;
    RuntimeError naming ``what`` when ``timeout`` s pass, or when one of
    ``procs`` ((name, Popen)) exits first."""
    end = time.monotonic() + timeout
    while True:
        value = predicate()
        if value:
            return value
        for name, p in procs:
            if p.poll() is not None:
                raise RuntimeError('%s exited with status %s while waiting '
                                   'for %s' % (name, p.returncode, what))
        if time.monotonic() > end:
            raise RuntimeError('timed out after %.0f s waiting for %s'
                               % (timeout, what))
        time.sleep(poll)


def wait_for_master(master_uri, timeout, procs=()):
    """Wait until a ROS master answers at ``master_uri`` (its getPid), as
    wait_until: a port from ``free_port`` may be taken by another
    process's server (a node's XML-RPC port) before the master binds it."""
    import rosgraph
    master = rosgraph.Master('/hri_sync_wait', master_uri=master_uri)

    def up():
        try:
            master.getPid()
            return True
        except Exception:   # refused, or not a master (yet)
            return False
    return wait_until('a ROS master at %s' % master_uri, up, timeout, procs)


def run_script(path, args):
    """Runs the script at ``path`` as ``__main__`` in this process, as
    its command line ``path ARGS`` would run: (its exit status, what it
    wrote to stdout and stderr, together).  For a test of a command-line
    tool that needs no fresh process: it saves the interpreter's start
    and the tool's imports (~2 CPU s for ``report``)."""
    out = io.StringIO()
    argv = sys.argv
    sys.argv = [path] + list(args)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(out):
            runpy.run_path(path, run_name='__main__')
        code = 0
    except SystemExit as e:
        if e.code is None or isinstance(e.code, int):
            code = e.code or 0
        else:   # sys.exit('message'): printed, status 1
            out.write('%s\n' % e.code)
            code = 1
    finally:
        sys.argv = argv
    return code, out.getvalue()


def percentiles_ms(values):
    """n, p50, p99, max and min (ms) of the finite ``values`` (s)."""
    vals = sorted(v for v in values if math.isfinite(v))
    if not vals:
        return {'n': 0}

    def pct(q):
        return vals[max(0, min(len(vals) - 1,
                               math.ceil(q / 100 * len(vals)) - 1))]
    return {'n': len(vals), 'p50_ms': pct(50) * 1e3, 'p99_ms': pct(99) * 1e3,
            'max_ms': vals[-1] * 1e3, 'min_ms': vals[0] * 1e3}


ONE_CLIENT_LAUNCH = """<launch>
  <arg name="ntp_port"/>
  <include file="$(find hri_sync)/launch/timeserver.launch">
    <arg name="ntp_port" value="$(arg ntp_port)"/>
  </include>
  <include file="$(find hri_sync)/launch/server.launch">
    <arg name="clients" value="a,{clients}"/>
    <arg name="participants" value="a"/>
    <arg name="rounds" value="{rounds}"/>
    <arg name="dur" value="{dur}"/>
    <arg name="ntp_port" value="$(arg ntp_port)"/>
    <arg name="required" value="false"/>{server}
  </include>
  <node pkg="hri_sync" type="synthetic_sensor" name="reference">
    <param name="rate" value="50.0"/>
    <param name="signal" value="sine"/>
  </node>
  <include file="$(find hri_sync)/launch/client.launch">
    <arg name="client_id" value="a"/>
    <arg name="ntp_port" value="$(arg ntp_port)"/>
    <arg name="input" value="/reference/samples"/>
    <arg name="stamp_source" value="arrival"/>
  </include>
  {body}
</launch>
"""


def add_start_args(parser, whose):
    """--spin and --realtime-priority: how ``whose`` start threads wait
    for a start (the launch args start_spin and realtime_priority)."""
    parser.add_argument('--spin', type=float, default=0.01,
                        help='start_spin of %s, s' % whose)
    parser.add_argument('--realtime-priority', type=int, default=10,
                        help='SCHED_FIFO priority of the start threads; '
                        '0: off')


def one_client_launch(clients, rounds, dur, body, **server_args):
    """A launch file's text: time server, server (with more server.launch
    args ``server_args``, e.g. ``round_pause=1.0``), one sensor client
    ``a`` (a 50 Hz synthetic sine, the only participant), the other
    ``clients`` (comma-separated ids) in the server's list, and ``body``
    (their nodes); arg ``ntp_port``."""
    server = ''.join('\n    <arg name="%s" value="%s"/>' % kv
                     for kv in sorted(server_args.items()))
    return ONE_CLIENT_LAUNCH.format(clients=clients, rounds=rounds, dur=dur,
                                    server=server, body=body)


def run_private_launch(path, observe, stop_wait=20.0, log=None):
    """roslaunch ``path`` (ntp_port:= a free port) with a master of its
    own on a free port (this process's ROS_MASTER_URI points at it), call
    ``observe(proc)``, then stop the launch (SIGINT, SIGKILL after
    ``stop_wait`` s); returns what ``observe`` returned.  The launch's
    output goes to the file object ``log``, or nowhere."""
    port = free_port()
    os.environ['ROS_MASTER_URI'] = 'http://localhost:%d' % port
    out = log if log is not None else subprocess.DEVNULL
    proc = subprocess.Popen(['roslaunch', '-p', str(port), path,
                             'ntp_port:=%d' % free_port()],
                            env=dict(os.environ), stdout=out,
                            stderr=subprocess.STDOUT if log is not None
                            else subprocess.DEVNULL, start_new_session=True)
    try:
        return observe(proc)
    finally:
        os.killpg(proc.pid, signal.SIGINT)
        try:
            proc.wait(timeout=stop_wait)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)


def ms(stats):
    """Seconds -> ms in a dict of figures, NaN -> None (valid JSON)."""
    return {k: round(v * 1e3, 4) if math.isfinite(v) else None
            for k, v in stats.items()}


class Interrupted(Exception):
    """SIGINT, SIGTERM, SIGHUP or the hard time bound (SIGALRM)."""


def run_bounded(run, stop, hard_bound, log=_log_nowhere):
    """Run ``run()`` with SIGINT/SIGTERM/SIGHUP and a SIGALRM after
    ``hard_bound`` s raising ``Interrupted``, then ``stop()`` whatever
    happened (signals during it only log).  Returns (exit status,
    failures): 0 and [] when ``run`` returned, 130 when interrupted, 2 when
    it raised RuntimeError (a setup failure) or anything else (a bug, still
    cleaned up); failures are (kind, note) pairs."""
    def on_signal(signum, _frame):
        raise Interrupted(signal.Signals(signum).name)
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP,
                signal.SIGALRM):
        signal.signal(sig, on_signal)
    status, failures = 0, []
    try:
        signal.alarm(max(1, int(math.ceil(hard_bound))))
        run()
    except Interrupted as e:
        failures.append(('interrupted', 'interrupted by %s' % e))
        log('interrupted (%s): cleaning up', e)
        status = 130
    except RuntimeError as e:
        failures.append(('setup_failed', 'setup failed: %s' % e))
        log('ERROR: setup failed: %s', e)
        status = 2
    except Exception as e:  # a bench bug: still clean up and report it
        failures.append(('error', 'bench error: %r' % e))
        log('ERROR: %r', e)
        status = 2
    finally:
        signal.alarm(0)
        for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
            signal.signal(sig, lambda *_: log('cleaning up, please wait'))
        stop()
    return status, failures
