"""scripts/run_rostests.py's scheduler: JOBS tests at once, up to
MAX_JOBS while the CPU is idle, every result reported once."""
import importlib.util
import os
import subprocess
import threading
import time

import pytest

from hri_sync_support.harness import wait_until

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..',
                      '..', 'scripts', 'run_rostests.py')
spec = importlib.util.spec_from_file_location('run_rostests', SCRIPT)
run_rostests = importlib.util.module_from_spec(spec)
spec.loader.exec_module(run_rostests)


class Fake:
    """Fake tests that count how many run at once; each lasts 1.5 s, or
    until ``enough`` of them ran at once."""

    def __init__(self, enough=99):
        self.lock = threading.Lock()
        self.enough = threading.Event()
        self.want = enough
        self.now = 0
        self.most = 0
        self.reported = []

    def run(self, name):
        with self.lock:
            self.now += 1
            self.most = max(self.most, self.now)
            if self.now >= self.want:
                self.enough.set()
        self.enough.wait(1.5)
        with self.lock:
            self.now -= 1
        return name

    def report(self, result):
        self.reported.append(result)


@pytest.mark.parametrize('idle, want', [
    (0.0, 2), (run_rostests.IDLE_MORE - 0.01, 2), (run_rostests.IDLE_MORE, 4)])
def test_more_tests_run_only_while_the_cpu_is_idle(idle, want):
    # the limit goes up by one per look (a second at most), up to 4
    t = Fake(enough=4)
    files = ['t%d' % i for i in range(4)]
    most = run_rostests.schedule(files, t.run, t.report, 2, 4,
                                 lambda: idle, ramp=0.0)
    assert sorted(t.reported) == sorted(files)
    assert t.most == most == want


def test_the_limit_is_never_below_least():
    # a busy CPU, but the stages are done: JOBS + 1 (here from the start)
    t = Fake(enough=3)
    files = ['t%d' % i for i in range(3)]
    most = run_rostests.schedule(files, t.run, t.report, 2, 4,
                                 lambda: 0.0, ramp=0.0, least=lambda: 3)
    assert t.most == most == 3


def test_the_limit_above_jobs_rises_one_per_ramp():
    t = Fake()
    files = ['t%d' % i for i in range(4)]
    # a ramp longer than the run: the limit rises once, at the start
    most = run_rostests.schedule(files, t.run, t.report, 2, 5,
                                 lambda: 1.0, ramp=60.0)
    assert t.most == most == 3
    assert len(t.reported) == 4


def test_the_limit_falls_back_to_jobs_when_the_cpu_is_busy():
    # idle for three looks (the limit up to 3), then busy: the limit is
    # back at 2 before the long tests end, so no quick test runs beside 2
    lock = threading.Lock()
    running = []
    beside = []
    gate = threading.Event()
    looks = [0]

    def run(name):
        with lock:
            running.append(name)
            if name.startswith('q'):
                beside.append(len(running))
        if name.startswith('long'):
            gate.wait(30)
        else:
            time.sleep(0.2)
        with lock:
            running.remove(name)
        return name

    def idle():
        looks[0] += 1
        if looks[0] > 3:
            gate.set()
            return 0.0
        return 1.0

    files = ['long%d' % i for i in range(3)] + ['q%d' % i for i in range(4)]
    most = run_rostests.schedule(files, run, lambda r: None, 2, 3, idle,
                                 ramp=0.0)
    assert most == 3 and len(beside) == 4 and max(beside) <= 2


def test_a_stage_is_a_named_shell_command():
    stage = run_rostests.Stage('unit=cd x && pytest -q a=b')
    assert (stage.name, stage.command) == ('unit', 'cd x && pytest -q a=b')
    assert run_rostests.job_name(stage) == 'unit'
    assert run_rostests.job_name('/t/rostest/fuzz.test') == 'fuzz'
    for bad in ('unit', '=pytest', 'unit='):
        with pytest.raises(Exception, match='NAME=COMMAND'):
            run_rostests.Stage(bad)


def test_a_stage_passes_on_exit_0_and_a_failed_one_shows_its_log(tmp_path):
    runner = run_rostests.Runner(str(tmp_path), False, None)
    name, ok, _, cpu, line = runner.run(run_rostests.Stage('good=exit 0'))
    assert (name, ok, cpu) == ('good', True, None)
    assert line.startswith('PASS good')
    name, ok, _, _, line = runner.run(
        run_rostests.Stage('bad=echo "the reason"; exit 3'))
    assert not ok and line.startswith('FAIL bad')
    assert '(exit 3, stage)' in line and 'the reason' in line
    with open(tmp_path / '.ws' / 'test_logs' / 'bad.log') as log:
        assert log.read() == 'the reason\n'


def test_an_interrupted_schedule_stops_its_running_jobs():
    stopped = threading.Event()

    def run(name):
        if name != 'quick':
            stopped.wait(30)        # runs until stopped
        return name

    def report(result):
        raise KeyboardInterrupt     # as SIGINT or SIGTERM would

    with pytest.raises(KeyboardInterrupt):
        run_rostests.schedule(['quick', 'long1', 'long2'], run, report, 3,
                              3, lambda: 0.0, stop=stopped.set)
    assert stopped.is_set()


def test_kill_all_ends_a_running_stage(tmp_path):
    runner = run_rostests.Runner(str(tmp_path), False, None)
    results = []
    job = threading.Thread(target=lambda: results.append(
        runner.run(run_rostests.Stage('long=sleep 60'))))
    job.start()
    wait_until('the stage to start', lambda: runner.running, 30)
    runner.kill_all()
    job.join(30)
    [(name, ok, _, _, line)] = results
    assert (name, ok) == ('long', False) and '(exit -9, stage)' in line
    assert runner.running == {}


def fake_rosversion(folder, code=0):
    """A ``rosversion`` in folder that logs each call and answers like the
    real one (or fails with ``code``)."""
    os.makedirs(folder)
    path = os.path.join(folder, 'rosversion')
    with open(path, 'w') as f:
        f.write('#!/bin/sh\necho "$*" >> %s/calls\n' % folder
                + 'case "$1" in -d) echo Debian ;; *) echo 1.15.15 ;; esac\n'
                + 'exit %d\n' % code)
    os.chmod(path, 0o755)
    return folder


def test_roslaunchs_rosversion_questions_are_answered_from_one_run(
        tmp_path, monkeypatch):
    real = fake_rosversion(str(tmp_path / 'real'))
    monkeypatch.setenv('PATH', real + os.pathsep + os.environ['PATH'])
    runner = run_rostests.Runner(str(tmp_path), False, None)
    path = runner.env()['PATH']
    assert path.split(os.pathsep)[0] == runner.bin != real
    for _ in range(3):
        for args, answer in ((['roslaunch'], '1.15.15\n'),
                             (['-d'], 'Debian\n')):
            out = subprocess.run(['rosversion'] + args, env={'PATH': path},
                                 capture_output=True, text=True)
            assert (out.returncode, out.stdout) == (0, answer)
    subprocess.run(['rosversion', 'rospy'], env={'PATH': path}, check=True)
    with open(os.path.join(real, 'calls')) as f:
        assert f.read().split('\n') == ['roslaunch', '-d', 'rospy', '']


def test_without_a_working_rosversion_nothing_is_cached(tmp_path, monkeypatch):
    real = fake_rosversion(str(tmp_path / 'real'), code=1)
    monkeypatch.setenv('PATH', real + os.pathsep + os.environ['PATH'])
    runner = run_rostests.Runner(str(tmp_path), False, None)
    assert runner.bin is None
    assert runner.env()['PATH'] == os.environ['PATH']


def test_idle_share_is_over_the_last_span_of_readings():
    now = [0.0]
    ticks = [(0, 0)]
    idle = run_rostests.IdleShare(span=5.0, read=lambda: ticks[0],
                                  clock=lambda: now[0])
    assert idle() == 0.0                    # not looked 5 s yet
    for t, busy, spare in ((2, 150, 50), (5, 300, 200), (7, 500, 200),
                           (10, 700, 200)):
        now[0], ticks[0] = t, (busy, spare)
        share = idle()
    # 5-10 s: 400 busy and 0 idle ticks; 0-5 s's idle does not count
    assert share == 0.0
    now[0], ticks[0] = 15, (800, 1100)
    assert idle() == pytest.approx(900 / 1000)


def test_idle_share_is_0_where_the_cpu_times_cannot_be_read():
    def unreadable():
        raise OSError('no /proc/stat')
    assert run_rostests.IdleShare(span=0.0, read=unreadable)() == 0.0


def test_cpu_times_reads_busy_and_idle_from_proc_stat(tmp_path):
    stat = tmp_path / 'stat'
    stat.write_text('cpu  10 1 5 100 4 2 3 0 0 0\ncpu0 5 0 2 50 2 1 1 0\n')
    assert run_rostests.cpu_times(str(stat)) == (21, 104)


def test_a_checkers_failed_case_fails_the_test_and_is_named(tmp_path):
    # rostest's own summary counts the checker as one passed test even
    # when its test cases failed; the checker's file beside it says so.
    (tmp_path / 'rostest-x.xml').write_text(
        '<testsuite errors="0" failures="0" tests="1">'
        '<testcase name="testx"/></testsuite>')
    (tmp_path / 'rosunit-x.xml').write_text(
        '<testsuite errors="1" failures="1" tests="3">'
        '<testcase name="test_a"/>'
        '<testcase name="test_b"><failure type="AssertionError">'
        '0.5 not less than 0.3 : right\n  File "x.py", line 3</failure>'
        '</testcase><testcase name="test_c"><error type="KeyError">'
        "'left'\n  File \"x.py\", line 9</error></testcase></testsuite>")
    summary = str(tmp_path / 'rostest-x.xml')
    assert run_rostests.junit_counts(summary) == (1, 2)
    assert run_rostests.junit_failures(summary) == [
        'test_b: 0.5 not less than 0.3 : right', "test_c: 'left'"]


def test_a_failures_message_is_its_lines_before_the_traceback():
    text = ("Items in the first set but not the second:\n'bad_stamps'\n"
            '  File "case.py", line 57, in testPartExecutor\n    yield')
    assert run_rostests.brief(text) == \
        "Items in the first set but not the second: / 'bad_stamps'"
    assert run_rostests.brief('x' * 500, most=10) == 'xxxxxxx...'


def test_a_missing_result_file_has_no_counts(tmp_path):
    assert run_rostests.junit_counts(str(tmp_path / 'none.xml')) is None
    assert run_rostests.junit_failures(str(tmp_path / 'none.xml')) == []


def test_a_test_that_runs_alone_runs_first_with_nothing_beside_it():
    lock = threading.Lock()
    running, order, beside = set(), [], []

    def run(name):
        with lock:
            running.add(name)
            order.append(name)
            if 'solo' in running and len(running) > 1:
                beside.append(sorted(running))
        time.sleep(0.3)
        with lock:
            running.discard(name)
        return name

    reported = []
    files = ['a', 'b', 'solo', 'c', 'd']
    most = run_rostests.schedule(files, run, reported.append, 3, 3,
                                 lambda: 0.0, ramp=0.0,
                                 alone=lambda f: f == 'solo')
    assert order[0] == 'solo' and not beside
    assert sorted(reported) == sorted(files) and most == 3


def test_a_file_runs_alone_where_it_has_the_line(tmp_path):
    solo, other = tmp_path / 'test_solo.py', tmp_path / 'test_other.py'
    solo.write_text('"""A live node.\n\nrun_rostests: alone\n"""\n')
    other.write_text('"""Says run_rostests: alone within a line."""\n')
    assert run_rostests.runs_alone(str(solo))
    assert not run_rostests.runs_alone(str(other))
    assert not run_rostests.runs_alone(str(tmp_path / 'missing.py'))
    assert not run_rostests.runs_alone(run_rostests.Stage('check=true'))
