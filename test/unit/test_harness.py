"""hri_sync.tools.procs and hri_sync_support.harness on real processes: the
/proc walker, process groups and their shutdown, faketime clocks, waits and
the bounded run.

``Processes`` makes this test process a child subreaper (for the rest of
the session: orphans of later tests are re-parented to it, which is
harmless).  Waits poll until a condition holds, with generous limits that
only stop a broken test; no duration is asserted.
"""
import math
import os
import random
import shutil
import signal
import socket
import subprocess
import sys
import time

import pytest

from hri_sync.tools import procs
from hri_sync_support import harness

LIMIT = 30.0    # s: only a broken test waits this long


def eventually(predicate, what):
    harness.wait_until(what, predicate, LIMIT, poll=0.02)


def live_group(pgid):
    """Live processes of process group ``pgid``."""
    return [pid for pid, info in procs.proc_table().items()
            if info.pgid == pgid and info.state not in procs.DEAD_STATES]


@pytest.fixture
def signals_restored():
    saved = {s: signal.getsignal(s) for s in (
        signal.SIGINT, signal.SIGTERM, signal.SIGHUP, signal.SIGALRM)}
    yield
    signal.alarm(0)
    for s, handler in saved.items():
        signal.signal(s, handler)


# ------------------------------------------------------------ the walker

def test_descendants_of_a_real_process_tree():
    child = subprocess.Popen(['sh', '-c', 'sleep 60 & sleep 60 & wait'],
                             start_new_session=True)
    try:
        # A forked child is named 'sh' until it has exec'd sleep (a race a
        # loaded machine shows): wait for both to be sleeps.
        eventually(lambda: [info.name for info in procs.descendants(
            child.pid).values()] == ['sleep', 'sleep'],
                   'sh and its two sleeps')
        tree = procs.descendants()
        assert child.pid in tree
        sleeps = [pid for pid, info in tree.items()
                  if info.ppid == child.pid]
        assert len(sleeps) == 2
        # The grandchildren are in the child's session and process group.
        assert {tree[pid].pgid for pid in sleeps} == {child.pid}
        assert tree[child.pid].pgid == child.pid
        assert procs.cmdline(child.pid).startswith('sh -c')
        assert procs.cmdline(child.pid, None) == \
            'sh -c sleep 60 & sleep 60 & wait'
        assert tree[child.pid].name == 'sh'
        assert {tree[pid].name for pid in sleeps} == {'sleep'}
        # Rooted at the child: only the grandchildren.
        assert set(procs.descendants(child.pid)) == set(sleeps)
    finally:
        os.killpg(child.pid, signal.SIGKILL)
        child.wait()
    eventually(lambda: not live_group(child.pid), 'the group to end')


def test_descendants_skip_zombies_but_walk_through_them():
    table = {
        10: procs.ProcInfo(1, 10, 'S', 0),     # the root
        11: procs.ProcInfo(10, 11, 'Z', 5),    # a zombie child
        12: procs.ProcInfo(11, 11, 'S', 6),    # its live child
        13: procs.ProcInfo(10, 13, 'R', 7),
        20: procs.ProcInfo(1, 20, 'S', 0),     # not ours
    }
    assert set(procs.descendants(10, table)) == {12, 13}


def test_an_unreaped_child_is_not_a_live_descendant():
    child = subprocess.Popen(['true'])
    eventually(lambda: procs.proc_table().get(
        child.pid, procs.ProcInfo(0, 0, 'Z', 0)).state == 'Z',
        'the child to be a zombie')
    assert child.pid not in procs.descendants()
    assert not procs.alive(child.pid)
    child.wait()
    assert not procs.alive(child.pid)
    assert procs.alive(os.getpid())


def test_cmdline_of_a_gone_process():
    child = subprocess.Popen(['true'])
    child.wait()
    assert procs.cmdline(child.pid) == '?'


# ------------------------------------------------- groups and their stop

def test_processes_stop_a_tree_with_an_orphan_and_a_stubborn_one(tmp_path):
    group = harness.Processes(str(tmp_path), dict(os.environ))
    # An orphan in a session of its own (its parent exits at once), found
    # because this process is a subreaper; and one ignoring SIGINT/SIGTERM.
    group.start('orphaner', ['sh', '-c', 'setsid sleep 60 & exit 0'])
    stubborn = group.start('stubborn',
                           ['sh', '-c', 'trap "" INT TERM; sleep 60'])
    eventually(lambda: any(procs.cmdline(p).startswith('sleep 60')
                           and info.ppid == os.getpid()
                           for p, info in procs.descendants().items()),
               'the orphaned sleep re-parented to us')
    eventually(lambda: len(procs.descendants(stubborn.pid)) == 1,
               'the stubborn sleep')
    assert group.stop(grace=0.5) == []
    assert group.descendants() == {}
    assert stubborn.returncode == -signal.SIGKILL
    assert os.path.exists(tmp_path / 'orphaner.log')


def test_stop_group_interrupts_the_whole_group():
    child = subprocess.Popen(['sh', '-c', 'sleep 60; echo not reached'],
                             start_new_session=True)
    # Until sh's child has exec'ed sleep, a SIGINT can be swallowed by
    # the forked shell (a loaded machine widens that window).
    eventually(lambda: any(procs.cmdline(p).startswith('sleep 60')
                           for p in live_group(child.pid)), 'sh and sleep')
    assert procs.stop_group(child) == -signal.SIGINT
    eventually(lambda: not live_group(child.pid), 'the sleep to end')


def test_stop_group_kills_a_group_that_ignores_sigint():
    child = subprocess.Popen(['sh', '-c', 'trap "" INT; sleep 60'],
                             start_new_session=True)
    eventually(lambda: len(live_group(child.pid)) == 2, 'sh and sleep')
    assert procs.stop_group(child, timeout=0.2) == -signal.SIGKILL
    eventually(lambda: not live_group(child.pid), 'the sleep to end')


# --------------------------------------------------------- fake clocks

def test_fake_clock_spec_and_readings():
    clock = harness.FakeClock(offset=1.5, rate=1.0002, t0=1000.0)
    assert clock.spec == '+1.500000s x1.000200000'
    assert harness.FakeClock(-0.25, 0.9999, 0.0).spec == \
        '-0.250000s x0.999900000'
    assert clock.drift_ppm == pytest.approx(200.0)
    assert clock.local(1000.0) == pytest.approx(1001.5)
    assert clock.local(1100.0) == pytest.approx(1101.52)
    assert clock.offset_at(1100.0) == pytest.approx(-1.52)
    moved = clock.started(1050.0)
    assert moved.local(1100.0) == pytest.approx(1101.51)
    assert harness.TRUE_CLOCK.offset_at(1e9) == 0.0


def test_random_clock_is_seeded_and_within_bounds():
    def draw(seed):
        rng = random.Random(seed)
        return [harness.random_clock(rng, 3.0, 200.0, 5.0)
                for _ in range(50)]
    clocks = draw(7)
    assert clocks == draw(7)
    assert all(abs(c.offset) <= 3.0 and abs(c.drift_ppm) <= 200.0
               and c.t0 == 5.0 for c in clocks)
    # The offset is drawn first, then the rate (the benches' seeds).
    rng = random.Random(7)
    first = (rng.uniform(-3.0, 3.0), 1 + rng.uniform(-200, 200) * 1e-6)
    assert (clocks[0].offset, clocks[0].rate) == first


@pytest.mark.skipif(shutil.which('faketime') is None,
                    reason='faketime is not installed')
def test_faketime_start_reads_when_the_faketime_process_started():
    before = time.time()
    child = subprocess.Popen(['faketime', '-f', '+10s', 'sleep', '60'],
                             start_new_session=True)
    after = time.time()
    try:
        eventually(lambda: procs.cmdline(child.pid).startswith(
            'faketime'), 'faketime to run')
        t0 = harness.faketime_start(os.getpid())
        # /proc counts 10 ms ticks: the start is floored to one.
        assert before - 0.02 <= t0 <= after + 0.02
    finally:
        os.killpg(child.pid, signal.SIGKILL)
        child.wait()
    assert harness.faketime_start(child.pid) is None
    eventually(lambda: not live_group(child.pid), 'the group to end')


@pytest.mark.skipif(shutil.which('faketime') is None,
                    reason='faketime is not installed')
def test_a_reading_of_a_faketime_clock_refers_its_drift_to_its_start():
    clock = harness.FakeClock(10.0, 1.01, 0.0)
    child = subprocess.Popen(['faketime', '-f', clock.spec, 'sleep', '60'],
                             start_new_session=True)
    try:
        # The child has exec'd sleep (before that, a fork of faketime has
        # not its clock's environment yet: seen once under load).
        eventually(lambda: any(
            info.ppid == child.pid and info.name == 'sleep'
            for info in procs.proc_table().values()),
            'faketime to start sleep')
        first = harness.faketime_reading(os.getpid())
        assert first is not None
        referred = clock.through(*first)
        time.sleep(0.5)
        true, faked = harness.faketime_reading(os.getpid())
        # 1 % drift: a start off by 1 ms would be 10 us off here.
        assert abs(referred.local(true) - faked) < 5e-5
        assert abs(clock.started(referred.t0 + 0.01).local(true)
                   - faked) > 5e-5
    finally:
        os.killpg(child.pid, signal.SIGKILL)
        child.wait()
    assert harness.faketime_reading(child.pid) is None


# ------------------------------------------------- reference and a run

def test_sensor_argv_is_a_true_clock_synthetic_sensor():
    assert harness.sensor_argv('/x/synthetic_sensor', 'reference', 100.0,
                               0.5) == [
        '/x/synthetic_sensor', '__name:=reference', '_rate:=100',
        '_phase:=0.5', '_signal:=true_time']


def test_free_port_can_be_bound():
    for kind in (socket.SOCK_STREAM, socket.SOCK_DGRAM):
        port = harness.free_port(kind)
        with socket.socket(socket.AF_INET, kind) as s:
            s.bind(('127.0.0.1', port))


def test_wait_until_names_what_it_waited_for():
    with pytest.raises(RuntimeError, match='waiting for the moon'):
        harness.wait_until('the moon', lambda: False, 0.0)
    child = subprocess.Popen([sys.executable, '-c', 'raise SystemExit(3)'])
    child.wait()
    with pytest.raises(RuntimeError, match='roscore exited with status 3 '
                       'while waiting for it'):
        harness.wait_until('it', lambda: False, LIMIT, [('roscore', child)])
    harness.wait_until('done', lambda: True, 0.0)


def test_ms_rounds_and_maps_nan_to_none():
    assert harness.ms({'p50': 0.0012345678, 'max': float('nan')}) == {
        'p50': 1.2346, 'max': None}


@pytest.mark.parametrize('body, status, kind', [
    (lambda: None, 0, None),
    (lambda: (_ for _ in ()).throw(RuntimeError('no roscore')), 2,
     'setup_failed'),
    (lambda: (_ for _ in ()).throw(KeyError('bug')), 2, 'error'),
])
def test_run_bounded_reports_how_the_run_ended(signals_restored, body,
                                               status, kind):
    stopped = []
    got, failures = harness.run_bounded(body, lambda: stopped.append(1),
                                        LIMIT)
    assert got == status and stopped == [1]
    assert [k for k, _ in failures] == ([kind] if kind else [])


def test_run_bounded_turns_sigterm_into_an_interrupt(signals_restored):
    def run():
        os.kill(os.getpid(), signal.SIGTERM)
        harness.wait_until('the signal', lambda: False, LIMIT)
    stopped = []
    status, failures = harness.run_bounded(run, lambda: stopped.append(1),
                                           LIMIT)
    assert status == 130 and stopped == [1]
    assert failures == [('interrupted', 'interrupted by SIGTERM')]


def test_percentiles_in_ms_skip_what_is_not_finite():
    percentiles_ms = harness.percentiles_ms
    assert percentiles_ms([math.nan]) == {'n': 0}
    p = percentiles_ms([0.001 * k for k in range(1, 101)] + [math.nan])
    assert p['n'] == 100
    assert (p['p50_ms'], p['p99_ms'], p['max_ms'], p['min_ms']) == \
        pytest.approx((50.0, 99.0, 100.0, 1.0))


def test_one_client_launch_lists_the_clients():
    import xml.etree.ElementTree as ET
    root = ET.fromstring(harness.one_client_launch('dj_rob,music', 3, 2.5,
                                           '<node name="x"/>'))
    server = root.findall('include')[1]
    args = {a.get('name'): a.get('value') for a in server.findall('arg')}
    assert (args['clients'], args['rounds'], args['dur']) == (
        'a,dj_rob,music', '3', '2.5')
    assert root.find('node[@name="x"]') is not None


def test_one_client_launch_passes_server_args():
    import xml.etree.ElementTree as ET
    root = ET.fromstring(harness.one_client_launch(
        'robot1', 2, 6.0, '', round_pause=1.0, min_expressiveness='1e9'))
    server = root.findall('include')[1]
    args = {a.get('name'): a.get('value') for a in server.findall('arg')}
    assert (args['round_pause'], args['min_expressiveness']) == ('1.0', '1e9')
