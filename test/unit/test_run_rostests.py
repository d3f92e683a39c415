"""scripts/run_rostests.py's scheduler: JOBS tests at once while the CPU
is busy, up to MAX_JOBS while it idles, every result reported once."""
import importlib.util
import os
import threading

import pytest

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


@pytest.mark.parametrize('idle, want', [(0.0, 2), (0.9, 4)])
def test_more_tests_run_only_while_the_cpu_idles(idle, want):
    # one more start per look (a second at most), up to 4
    t = Fake(enough=4)
    files = ['t%d' % i for i in range(4)]
    most = run_rostests.schedule(files, t.run, t.report, 2, 4,
                                 idle=lambda: idle, ramp=0.0)
    assert sorted(t.reported) == sorted(files)
    assert t.most == most == want


def test_the_tests_above_jobs_start_one_per_ramp():
    t = Fake()
    files = ['t%d' % i for i in range(4)]
    # a ramp longer than the run: one extra test at the start, no other
    most = run_rostests.schedule(files, t.run, t.report, 2, 5,
                                 idle=lambda: 1.0, ramp=60.0)
    assert t.most == most == 3
    assert len(t.reported) == 4


def test_the_idle_meter_reads_a_share():
    meter = run_rostests.IdleMeter()
    assert meter.idle() == 0.0      # one sample: no window yet
    meter.samples[0] = (meter.samples[0][0] - run_rostests.IDLE_WINDOW,
                        meter.samples[0][1], meter.samples[0][2] - 1)
    assert 0.0 <= meter.idle() <= 1.0
