"""Precise waits, real-time scheduling and the unfaked host clock."""
import os
import shutil
import subprocess
import sys
import time

import pytest

from hri_sync.clock.truth import true_time, realtime, wait_until

SRC = os.path.join(os.path.dirname(__file__), '..', '..', 'src')


def test_host_time_is_the_system_clock():
    """Read between two system clock reads (a busy machine may preempt
    the test between any two reads, so no fixed gap is asserted)."""
    before = time.time()
    t = true_time()
    after = time.time()
    assert before - 1e-6 <= t <= after + 1e-6


@pytest.mark.skipif(shutil.which('faketime') is None,
                    reason='faketime is not installed')
def test_host_time_bypasses_libfaketime():
    code = ('import time; from hri_sync.clock.truth import true_time; '
            'print(true_time() - time.time())')
    out = subprocess.run(
        ['faketime', '-f', '+100s', sys.executable, '-c', code],
        env=dict(os.environ, PYTHONPATH=os.path.abspath(SRC)),
        capture_output=True, text=True, check=True, timeout=30)
    assert float(out.stdout) == pytest.approx(-100.0, abs=0.5)


def test_wait_until_returns_at_the_target():
    for _ in range(5):
        target = time.time() + 0.05
        late = wait_until(time.time, target)
        now = time.time()
        # It reports how late it returned: never early, and no later
        # than the clock read after it (load makes both larger; the
        # figure belongs to bench/).
        assert now >= target
        assert 0.0 <= late <= now - target


def test_wait_until_on_a_shifted_clock_and_stop():
    def shifted():
        return time.time() + 1000.0
    target = shifted() + 0.03
    assert wait_until(shifted, target) is not None
    assert shifted() >= target
    assert wait_until(time.time, time.time() + 5.0,
                      stop=lambda: True) is None


def test_realtime_is_restored_or_refused_with_a_reason():
    before = os.sched_getscheduler(0)
    with realtime(5) as rt:
        if rt.ok:
            assert os.sched_getscheduler(0) == os.SCHED_FIFO
        else:
            assert rt.error
    assert os.sched_getscheduler(0) == before
    with realtime(0) as off:
        assert not off.ok and off.error == 'not requested'
