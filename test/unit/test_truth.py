"""Precise waits, real-time scheduling and the unfaked host clock."""
import os
import shutil
import subprocess
import sys
import time

import pytest

from hri_sync.clock.truth import (KEPT_INTERVAL, KeptGil, pause, realtime,
                                  true_time, turn, wait_until)

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


class FakeTime:
    """A clock that only the waits advance; it logs each wait with the
    time left to the target when it began."""

    def __init__(self, target, step=0.0004):
        self.t, self.target, self.step, self.log = 0.0, target, step, []
        self.interval = 0.005
        self.kept = KeptGil((lambda: self.interval, self.set_interval))

    def set_interval(self, value):
        self.log.append(('interval', value))
        self.interval = value

    def now(self):
        return self.t

    def waiter(self, kind, fixed=None):
        def wait(seconds=None):
            self.log.append((kind, self.target - self.t))
            # A real wait takes some time, however short its argument.
            self.t += fixed if fixed is not None else max(seconds, 1e-6)
        return wait

    def wait(self, keep=True, **kw):
        return wait_until(self.now, self.target,
                          kept=self.kept if keep else None,
                          sleep=self.waiter('sleep'),
                          pause=self.waiter('pause'),
                          turn=self.waiter('turn', self.step),
                          free_turn=self.waiter('free_turn', self.step), **kw)


def test_wait_until_keeps_the_gil_from_hold_before_the_target():
    clock = FakeTime(target=1.0)
    late = clock.wait(spin=0.002, hold=0.022)
    assert late == pytest.approx(clock.t - 1.0) and 0 <= late < 0.0004
    kinds = [k for k, _ in clock.log]
    # Sleeps (GIL released) up to 22 ms before; then the GIL is kept
    # (switch interval raised once), paused to 2 ms before, then turns.
    first_kept = kinds.index('interval')
    assert set(kinds[:first_kept]) == {'sleep'}
    assert clock.log[first_kept] == ('interval', KEPT_INTERVAL)
    assert kinds.count('interval') == 1
    assert all(left > 0.022 - 1e-9 for k, left in clock.log if k == 'sleep')
    assert all(0.002 < left <= 0.022 + 1e-9
               for k, left in clock.log if k == 'pause')
    assert 'pause' in kinds
    assert all(left <= 0.002 + 1e-9 for k, left in clock.log if k == 'turn')
    assert kinds[-1] == 'turn'
    # Kept until the caller releases it; then the interval is back.
    assert clock.interval == KEPT_INTERVAL
    clock.kept.release()
    assert clock.interval == 0.005
    clock.kept.release()
    assert clock.log[-1] == ('interval', 0.005)


def test_wait_until_without_kept_leaves_the_switch_interval():
    clock = FakeTime(target=0.5)
    clock.wait(keep=False, spin=0.003, hold=0.03)
    kinds = {k for k, _ in clock.log}
    # Its spin releases the GIL at each turn (start threads of one
    # process take turns).
    assert kinds == {'sleep', 'pause', 'free_turn'}
    assert clock.interval == 0.005


def test_wait_until_stops_before_keeping_the_gil():
    clock = FakeTime(target=5.0)
    assert clock.wait(spin=0.002, hold=0.03, stop=lambda: True) is None
    assert clock.log == [] and clock.interval == 0.005


def test_kept_gil_restores_at_the_end_of_the_block():
    before = sys.getswitchinterval()
    with KeptGil() as kept:
        kept.keep()
        assert sys.getswitchinterval() == max(before, KEPT_INTERVAL)
    assert sys.getswitchinterval() == before


def test_pause_and_turn_return():
    before = time.monotonic()
    pause(0.002)
    turn()
    assert time.monotonic() >= before + 0.002
