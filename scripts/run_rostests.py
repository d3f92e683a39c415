#!/usr/bin/python3
"""Run every rostest in a folder, several at once, and summarise.

    run_rostests.py [-j N] [--stage NAME=COMMAND ...] TEST_DIR [NAME ...]

Runs TEST_DIR/rostest/*.test with rostest, and the script-driven tests,
TEST_DIR/system/test_*.py, with pytest: those need what rostest cannot
give (e.g. a master they restart) and start their own processes.  Each
--stage is a shell command run beside them, as one more job of the same
pool (``make test`` gives it pytest, check_package, install_space and
site_multihost): on a CPU-bound suite one pool, longest job first, ends
its jobs together, where a chain of stages run beside the pool ended
up to a minute after it on half the cores.

N jobs run at once (N + 1 once every stage is done), and up to M
(--max-jobs, default N + 2) while the machine has CPU to spare: every 5 s
the limit goes up by one when at least a fifth of the CPU time was idle
over the last 5 s, and down by one (not below those) when under 5 % was.
Many rostests mostly wait (for a round, a timeout), so N of them leave
cores idle that more can use; a busy machine runs N, then N + 1.  A test
file with the line 'run_rostests: alone' in it (a live node compared with
a recording of it, which a node starved of CPU fails) runs first, with
nothing beside it.  Run as
root, each test gets a network namespace of its own (loopback only), so
the tests' masters, NTP servers and node ports never meet, whatever
ports they hard-code; the namespace and every process left in it are
removed when the test ends.  Not root, the tests run one after another
on this host's network (-j is ignored).
The longest tests start first: by the durations of the last run, kept in
.ws/test_logs/durations.json, or on a fresh clone by those of a run on
this project's machine (TEST_DIR/durations.json, refreshed by hand).

Each test's (and stage's) full output goes to .ws/test_logs/<name>.log;
a failing one's tail is printed.  A stage runs in this host's network
namespace, its processes plain (no fork server).  Where the cgroup v1 cpuacct controller is
mounted, each test's processes share a cgroup and the line gives the CPU
time they used.  The last line is 'rostest: N passed, N failed';
the exit status is non-zero when any test failed or none ran.
"""
import argparse
import collections
import concurrent.futures
import glob
import json
import os
import shlex
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import xml.etree.ElementTree as ET

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path[:0] = [os.path.join(ROOT, 'src'), os.path.join(ROOT, 'support')]
from hri_sync.tools.procs import signal_each  # noqa: E402
from hri_sync_support.harness import wait_until  # noqa: E402

TIMEOUT = 600  # s per test file
STAGE_TIMEOUT = 3600  # s per stage (pytest beside the rostests on a busy machine)
TAIL = 60     # lines of a failed job's log printed
ALONE = 'run_rostests: alone'   # a test file's line: nothing runs beside it
NETNS_PREFIX = 'hrit'
CPUACCT = '/sys/fs/cgroup/cpuacct'
RAMP = 5.0          # s between changes of the limit of jobs at once
IDLE_MORE = 0.20    # CPU idle share over the last RAMP: one job more
IDLE_FEWER = 0.05   # under it: one fewer (not below the floor)


def junit_suites(path):
    """The testsuite elements of a JUnit XML file, or None."""
    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError):
        return None
    return [root] if root.tag == 'testsuite' else root.findall('testsuite')


def junit_counts(path):
    """(tests, failures + errors) of a JUnit XML file and of the checkers'
    files beside it (rostest's summary counts each checker as one test,
    passed even when its test cases failed), or None."""
    suites = junit_suites(path)
    if suites is None:
        return None
    tests = sum(int(s.get('tests', 0)) for s in suites)
    suites += [s for p in checker_files(path) for s in junit_suites(p) or []]
    bad = sum(int(s.get('failures', 0)) + int(s.get('errors', 0))
              for s in suites)
    return tests, bad


def checker_files(path):
    """The checkers' JUnit files beside a summary one."""
    return sorted(glob.glob(os.path.join(os.path.dirname(path),
                                         'rosunit-*.xml')))


def brief(text, most=400):
    """A failure's message on one line: its lines before the traceback,
    joined, at most ``most`` characters."""
    lines = []
    for line in text.splitlines():
        if line.lstrip().startswith(('File "', 'Traceback (most recent')):
            break
        lines.append(line.strip())
    one = ' / '.join(line for line in lines if line)
    return one if len(one) <= most else one[:most - 3] + '...'


def junit_failures(path):
    """'test case: message' of each failed or erred test case in a JUnit
    XML file and in the checkers' files beside it."""
    found = []
    for p in [path] + checker_files(path):
        for s in junit_suites(p) or []:
            for case in s.iter('testcase'):
                for bad in list(case.findall('failure')) \
                        + list(case.findall('error')):
                    text = (bad.get('message') or bad.text or '').strip()
                    found.append('%s: %s' % (case.get('name'),
                                             brief(text) or bad.tag))
    return found


def restore_signals():
    """SIGINT and SIGQUIT back to their defaults when this script was
    started with them ignored (in the background by a non-interactive
    shell): the tests' processes inherit them, and roslaunch and the
    checkers stop nodes with SIGINT."""
    if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)
    if signal.getsignal(signal.SIGQUIT) == signal.SIG_IGN:
        signal.signal(signal.SIGQUIT, signal.SIG_DFL)


def interrupt(_signum, _frame):
    """SIGTERM's handler: as SIGINT, the run stops and kills its jobs."""
    raise KeyboardInterrupt


def can_isolate():
    """True when this process may make network namespaces."""
    return os.geteuid() == 0 and subprocess.run(
        ['ip', 'netns', 'list'], stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL).returncode == 0


def netns_pids(ns):
    out = subprocess.run(['ip', 'netns', 'pids', ns], capture_output=True,
                         text=True).stdout
    return [int(p) for p in out.split()]


def can_fork_serve():
    """Whether the fork server can run here: it watches its forks with
    pidfds (Linux 5.3, Python 3.9)."""
    try:
        os.close(os.pidfd_open(os.getpid()))
    except (AttributeError, OSError):
        return False
    return True


def remove_netns(ns):
    """Kill what still runs in namespace ns, then delete it."""
    for sig in (signal.SIGTERM, signal.SIGKILL):
        pids = netns_pids(ns)
        for pid in pids:
            try:
                os.kill(pid, sig)
            except ProcessLookupError:
                pass
        deadline = time.monotonic() + 5
        while pids and netns_pids(ns) and time.monotonic() < deadline:
            time.sleep(0.1)
    subprocess.run(['ip', 'netns', 'del', ns], stderr=subprocess.DEVNULL)


class Stage:
    """A --stage: a shell command run as one job of the pool."""

    def __init__(self, spec):
        self.name, sep, self.command = spec.partition('=')
        if not sep or not self.name or not self.command:
            raise argparse.ArgumentTypeError(
                'a stage is NAME=COMMAND, not %r' % spec)

    def __repr__(self):
        return 'Stage(%r)' % self.name


def cpu_times(path='/proc/stat'):
    """(busy, idle) CPU time of all cores since boot, in clock ticks."""
    with open(path) as f:
        ticks = [int(t) for t in f.readline().split()[1:9]]
    idle = ticks[3] + ticks[4]              # idle, iowait
    return sum(ticks) - idle, idle


class IdleShare:
    """Called, the share of the machine's CPU time that was idle over
    the last ``span`` s (0 until it has looked that long, or where
    /proc/stat cannot be read)."""

    def __init__(self, span=RAMP, read=cpu_times, clock=time.monotonic):
        self.span = span
        self.read = read
        self.clock = clock
        self.readings = collections.deque()

    def __call__(self):
        try:
            busy, idle = self.read()
        except (OSError, ValueError, IndexError):
            return 0.0
        now = self.clock()
        self.readings.append((now, busy, idle))
        while (len(self.readings) > 1
               and now - self.readings[1][0] >= self.span):
            self.readings.popleft()
        then, busy0, idle0 = self.readings[0]
        total = (busy - busy0) + (idle - idle0)
        if now - then < self.span or total <= 0:
            return 0.0
        return (idle - idle0) / total


def job_name(job):
    """A test file's name without its extension, or a stage's name."""
    if isinstance(job, Stage):
        return job.name
    return os.path.splitext(os.path.basename(job))[0]


def runs_alone(job):
    """Whether a test file has the line ALONE (a stage never has)."""
    if isinstance(job, Stage):
        return False
    try:
        with open(job) as f:
            return any(line.strip(' #') == ALONE
                       for line in f.read().splitlines())
    except OSError:
        return False


def schedule(files, run, report, jobs, max_jobs, idle, ramp=RAMP,
             stop=lambda: None, least=None, alone=lambda job: False):
    """Runs ``run(file)`` for each of ``files``: first those ``alone(file)``
    says need the machine to themselves, one at a time with nothing beside
    them; then the others in order, ``jobs`` at once
    and up to ``max_jobs`` while the CPU has time to spare: every
    ``ramp`` s the limit goes up by one when ``idle()`` (the CPU's idle
    share) is at least IDLE_MORE, and down by one when it is under
    IDLE_FEWER, never below ``least()`` (default ``jobs``).  ``report``
    gets each result as it comes.  Interrupted (SIGINT, or SIGTERM as
    main sets it), it starts no more, calls ``stop()`` to end the running
    ones and raises.  Returns the most that ran at once."""
    with concurrent.futures.ThreadPoolExecutor(max_jobs) as pool:
        try:
            files = list(files)
            solo = [f for f in files if alone(f)]
            most = _run_all(pool, list(solo), run, report, 1, idle, ramp,
                            lambda: 1)
            return max(most, _run_all(
                pool, [f for f in files if f not in solo], run, report,
                max_jobs, idle, ramp, least or (lambda: jobs)))
        except BaseException:
            stop()
            raise


def _run_all(pool, pending, run, report, max_jobs, idle, ramp, least):
    """schedule's loop, on ``pool``."""
    running = set()
    limit = least()
    last_change = -ramp
    most = 0
    while pending or running:
        if pending and time.monotonic() - last_change >= ramp:
            last_change = time.monotonic()
            share = idle()
            if share >= IDLE_MORE:
                limit += 1
            elif share < IDLE_FEWER:
                limit -= 1
            limit = min(max_jobs, max(least(), limit))
        while pending and len(running) < limit:
            running.add(pool.submit(run, pending.pop(0)))
            most = max(most, len(running))
        done, running = concurrent.futures.wait(
            running, timeout=1.0,
            return_when=concurrent.futures.FIRST_COMPLETED)
        for future in done:
            report(future.result())
    return most


class CpuAccount:
    """A cpuacct cgroup the command's processes run in (a no-op where
    the controller is not mounted or writable)."""

    def __init__(self, name):
        self.path = os.path.join(CPUACCT, name)
        try:
            os.mkdir(self.path)
        except OSError:
            self.path = None

    def wrap(self, command):
        """command, started inside the cgroup."""
        if not self.path:
            return command
        procs = os.path.join(self.path, 'cgroup.procs')
        return ['sh', '-c', 'echo $$ > %s && exec "$@"' % procs,
                'sh'] + command

    def pids(self):
        """The processes in the cgroup now."""
        try:
            with open(os.path.join(self.path, 'cgroup.procs')) as f:
                return [int(p) for p in f.read().split()]
        except (OSError, TypeError, ValueError):
            return []

    def close(self):
        """CPU seconds used, or None; removes the cgroup (left behind,
        empty of processes, only while one of them still lingers)."""
        if not self.path:
            return None
        try:
            with open(os.path.join(self.path, 'cpuacct.usage')) as f:
                seconds = int(f.read()) / 1e9
        except (OSError, ValueError):
            seconds = None
        try:
            os.rmdir(self.path)
        except OSError:
            pass
        return seconds


def stale(name):
    """True for a namespace or cgroup name of a run of this script that
    is gone."""
    parts = name.split('_')
    return len(parts) == 3 and parts[0] == NETNS_PREFIX \
        and parts[1].isdigit() and not os.path.exists('/proc/%s' % parts[1])


def remove_stale_netns():
    """Namespaces of an earlier run of this script that was killed, and
    its cgroups left empty."""
    out = subprocess.run(['ip', 'netns', 'list'], capture_output=True,
                         text=True).stdout
    for line in out.splitlines():
        ns = line.split()[0] if line.split() else ''
        if stale(ns):
            remove_netns(ns)
    for name in os.listdir(CPUACCT) if os.path.isdir(CPUACCT) else []:
        if stale(name):
            try:
                os.rmdir(os.path.join(CPUACCT, name))
            except OSError:
                pass    # a process of it still runs


class Runner:
    """Runs test files, each alone in a namespace when isolate is set."""

    def __init__(self, root, isolate, mother):
        self.support = os.path.join(root, 'support')
        self.mother = mother     # the mother fork server's socket, or None
        self.logs = os.path.join(root, '.ws', 'test_logs')
        self.results = os.path.join(root, '.ws', 'test_results')
        self.isolate = isolate
        self.lock = threading.Lock()
        self.count = 0
        self.running = {}       # a running job's pid: its CpuAccount or None
        os.makedirs(self.logs, exist_ok=True)
        self.bin = self.cache_rosversion(os.path.join(root, '.ws', 'test_bin'))

    @staticmethod
    def cache_rosversion(folder):
        """A folder whose ``rosversion`` answers ``rosversion roslaunch``
        and ``rosversion -d`` from one run of the real one (and runs it for
        anything else), or None.  Every roslaunch (each rostest's, and those
        the tests start) asks both for its /rosversion and /rosdistro
        params: ~300 Python processes a suite, ~19 CPU s."""
        real = shutil.which('rosversion')
        answers = {}
        for args in ('roslaunch', '-d'):
            out = subprocess.run([real, args], capture_output=True,
                                 text=True) if real else None
            if out is None or out.returncode or not out.stdout.strip():
                return None
            answers[args] = out.stdout.strip()
        os.makedirs(folder, exist_ok=True)
        path = os.path.join(folder, 'rosversion')
        with open(path + '.tmp', 'w') as f:
            f.write('#!/bin/sh\n# %s, its answers to roslaunch cached by '
                    'scripts/run_rostests.py\ncase "$*" in\n' % real)
            for args, answer in answers.items():
                f.write('  %s) echo %s ;;\n' % (args, shlex.quote(answer)))
            f.write('  *) exec %s "$@" ;;\nesac\n' % shlex.quote(real))
        os.chmod(path + '.tmp', 0o755)
        os.replace(path + '.tmp', path)
        return folder

    def summary_xml(self, name):
        """The summary JUnit file of test ``name``."""
        return os.path.join(self.results, name, 'hri_sync',
                            'rostest-%s.xml' % name)

    def command(self, path, name):
        """(its summary XML, the command) of one test.  Each test writes
        its results in a folder of its own: tests that include one launch
        file name their checkers alike, and would overwrite each other's
        result files when run at once."""
        results = os.path.join(self.results, name)
        xml = self.summary_xml(name)
        if path.endswith('.py'):
            return xml, [sys.executable, '-m', 'pytest', '-q', '-p',
                         'no:cacheprovider', '--junitxml', xml, path]
        rostest = ['rostest', '--results-base-dir', results,
                   '--results-filename', '%s.xml' % name,
                   'hri_sync', os.path.basename(path)]
        if not self.mother:
            return xml, rostest
        # (a short path: a socket's is at most 107 bytes)
        with self.lock:
            self.count += 1
            sock = os.path.join(tempfile.gettempdir(), 'hri_sync_fork_%d_%d'
                                % (os.getpid(), self.count))
        return xml, [sys.executable, '-m', 'hri_sync_support.forkserver',
                     '--from', self.mother, sock, '--'] + rostest

    def env(self):
        """The environment of a test (and of the mother): support/ first
        on the PYTHONPATH, the cached rosversion first on PATH."""
        env = dict(os.environ)
        env['PYTHONPATH'] = os.pathsep.join(
            [self.support] + [p for p in env.get('PYTHONPATH', '').split(
                os.pathsep) if p])
        if self.bin:
            env['PATH'] = os.pathsep.join([self.bin, env.get('PATH', '')])
        return env

    def start_mother(self):
        """The mother fork server (the preloading done once for every
        test), or None."""
        if not self.mother:
            return None
        proc = subprocess.Popen(
            [sys.executable, '-m', 'hri_sync_support.forkserver',
             '--mother', self.mother], env=self.env(),
            start_new_session=True)
        try:
            wait_until('its socket', lambda: os.path.exists(self.mother),
                       60, [('it', proc)], poll=0.05)
        except RuntimeError as e:   # each test's launcher serves itself
            print('rostest: fork server mother: %s' % e, flush=True)
        return proc

    def run(self, job):
        """(name, ok, seconds, cpu seconds, summary line) of one job."""
        if isinstance(job, Stage):
            return self.run_stage(job)
        name = job_name(job)
        xml, command = self.command(job, name)
        # (the checkers' files of a run before would count as this one's)
        shutil.rmtree(os.path.join(self.results, name), ignore_errors=True)
        ns = None
        cpu = None
        env = self.env()
        if self.isolate:
            ns = self.unique_name()
            cpu = CpuAccount(ns)
            subprocess.run(['ip', 'netns', 'add', ns], check=True)
            subprocess.run(['ip', 'netns', 'exec', ns, 'ip', 'link', 'set',
                            'lo', 'up'], check=True)
            # Wrapped outside: `ip netns exec` mounts a sysfs of its own.
            command = cpu.wrap(['ip', 'netns', 'exec', ns] + command)
            env.update(ROS_HOSTNAME='localhost',
                       ROS_MASTER_URI='http://localhost:11311')
            env.pop('ROS_IP', None)
        t0 = time.monotonic()
        try:
            code = self.execute(command, env, name, TIMEOUT, cpu)
        finally:
            if ns:
                remove_netns(ns)
        seconds = time.monotonic() - t0
        counts = junit_counts(xml)
        ok = code == 0 and counts is not None and counts[0] > 0 \
            and counts[1] == 0
        return self.result(name, ok, seconds, cpu, code, '%d tests, %d failed'
                           % counts if counts else 'no result file')

    def run_stage(self, stage):
        """As run, for a --stage: its command in bash, on this host's
        network, its processes plain; passed when it exits 0."""
        cpu = CpuAccount(self.unique_name()) if self.isolate else None
        command = ['bash', '-c', stage.command]
        t0 = time.monotonic()
        code = self.execute(cpu.wrap(command) if cpu else command,
                            dict(os.environ), stage.name, STAGE_TIMEOUT, cpu)
        return self.result(stage.name, code == 0, time.monotonic() - t0,
                           cpu, code, 'stage')

    def unique_name(self):
        """A namespace or cgroup name of this run (see stale)."""
        with self.lock:
            self.count += 1
            return '%s_%d_%d' % (NETNS_PREFIX, os.getpid(), self.count)

    def execute(self, command, env, name, timeout, cpu):
        """command's exit status (its output in name's log), or a
        timeout's description after it was killed (``kill``)."""
        with open(os.path.join(self.logs, name + '.log'), 'w') as out:
            proc = subprocess.Popen(command, stdout=out,
                                    stderr=subprocess.STDOUT, env=env,
                                    start_new_session=True)
            with self.lock:
                self.running[proc.pid] = cpu
            try:
                return proc.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                self.kill(proc.pid, cpu)
                proc.wait()
                return 'timeout after %d s' % timeout
            finally:
                with self.lock:
                    self.running.pop(proc.pid, None)

    @staticmethod
    def kill(pid, cpu):
        """SIGKILL to a job's process group and to every process of its
        cgroup (a node in a group of its own, a stage's too)."""
        signal_each([-pid] + (cpu.pids() if cpu else []), signal.SIGKILL)

    def kill_all(self):
        """Kill every running job (an interrupted run)."""
        with self.lock:
            jobs = list(self.running.items())
        for pid, cpu in jobs:
            self.kill(pid, cpu)

    def result(self, name, ok, seconds, cpu, code, what):
        """The job's result tuple; a failed job's line ends with the tail
        of its log."""
        cpu_seconds = cpu.close() if cpu else None
        line = '%-4s %-40s %6.1f s%s  (exit %s, %s)' % (
            'PASS' if ok else 'FAIL', name, seconds,
            '' if cpu_seconds is None else ', cpu %5.1f s' % cpu_seconds,
            code, what)
        if not ok:
            line += ''.join('\n  %s' % f for f in junit_failures(
                self.summary_xml(name)))
            log = os.path.join(self.logs, name + '.log')
            with open(log) as lf:
                tail = lf.readlines()[-TAIL:]
            line += '\n  --- tail of %s ---\n%s' % (
                log, ''.join('  ' + t for t in tail))
        return name, ok, seconds, cpu_seconds, line


def main():
    restore_signals()
    signal.signal(signal.SIGTERM, interrupt)
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('-j', '--jobs', type=int,
                        default=int(os.environ.get('ROSTEST_JOBS', 4)),
                        help='jobs at once (default $ROSTEST_JOBS or 4)')
    parser.add_argument('--max-jobs', type=int,
                        default=os.environ.get('ROSTEST_MAX_JOBS'),
                        help='jobs at once while the CPU is a fifth idle '
                        '(default $ROSTEST_MAX_JOBS or JOBS + 2)')
    parser.add_argument('--stage', type=Stage, action='append', default=[],
                        metavar='NAME=COMMAND', help='a shell command run '
                        'as one more job; passed when it exits 0')
    parser.add_argument('test_dir')
    parser.add_argument('wanted', nargs='*', help='name substrings')
    args = parser.parse_args()
    test_dir = os.path.abspath(args.test_dir)
    root = os.path.dirname(test_dir)
    files = sorted(glob.glob(os.path.join(test_dir, 'rostest', '*.test'))) \
        + sorted(glob.glob(os.path.join(test_dir, 'system', 'test_*.py')))
    files = [f for f in files
             if not args.wanted or any(w in f for w in args.wanted)]
    isolate = can_isolate()
    jobs = max(1, args.jobs) if isolate else 1
    max_jobs = max(jobs, args.max_jobs if args.max_jobs is not None
                   else jobs + 2) if isolate else 1
    if isolate:
        remove_stale_netns()
    fork = os.environ.get('ROSTEST_FORKSERVER', '1') != '0' \
        and can_fork_serve()
    runner = Runner(root, isolate, os.path.join(
        tempfile.gettempdir(), 'hri_sync_mother_%d' % os.getpid())
        if fork else None)
    durations_file = os.path.join(runner.logs, 'durations.json')
    durations = {}
    for path in (os.path.join(test_dir, 'durations.json'), durations_file):
        try:
            with open(path) as f:
                durations.update(json.load(f))
        except (OSError, ValueError):
            pass
    stages = args.stage
    pool = sorted(stages + files,
                  key=lambda job: -durations.get(job_name(job), 60.0))
    print('rostest: %d files%s, %d at once%s%s%s'
          % (len(files), ' and %d stages (%s)' % (
              len(stages), ', '.join(s.name for s in stages))
             if stages else '', jobs, ' (up to %d while the CPU is idle)'
             % max_jobs if max_jobs > jobs else '',
             ', one network namespace each' if isolate else
        ' (not root: no network namespaces, one at a time)',
        ', Python forked from a preloaded server' if runner.mother else ''),
        flush=True)
    solo = [job for job in pool if runs_alone(job)]
    if solo:
        print('rostest: first, with nothing beside it: %s'
              % ', '.join(map(job_name, solo)), flush=True)
    passed, failed = [], []
    cpu_total = 0.0
    t0 = time.monotonic()

    def report(result):
        nonlocal cpu_total
        name, ok, seconds, cpu_seconds, line = result
        durations[name] = round(seconds, 1)
        cpu_total += cpu_seconds or 0.0
        (passed if ok else failed).append(name)
        print(line, flush=True)
    idle = IdleShare()
    stage_names = {s.name for s in stages}

    def least():
        """JOBS, and one more once the stages are done (the cores they
        left, whatever else the machine runs)."""
        return jobs + (bool(stages) and stage_names <= set(passed + failed))
    mother = runner.start_mother()
    try:
        most = schedule(pool, runner.run, report, jobs, max_jobs, idle,
                        stop=runner.kill_all, least=least,
                        alone=solo.__contains__)
    except KeyboardInterrupt:
        print('rostest: interrupted: the running jobs were killed',
              flush=True)
        sys.exit(130)
    finally:
        if mother:
            mother.terminate()
            mother.wait()
    with open(durations_file, 'w') as f:
        json.dump(durations, f, indent=1, sort_keys=True)
    print('rostest: wall %.1f s, sum of job times %.1f s, cpu %.1f s, '
          'up to %d at once' % (
              time.monotonic() - t0, sum(durations.get(job_name(job), 0)
                                         for job in pool), cpu_total, most))
    if failed:
        print('rostest: failed: %s' % ' '.join(sorted(failed)))
    print('rostest: %d passed, %d failed' % (len(passed), len(failed)))
    sys.exit(1 if failed or not passed else 0)


if __name__ == '__main__':
    main()
