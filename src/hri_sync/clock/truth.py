"""The true clock (the host's unfaked CLOCK_REALTIME) and precise waits.

No ROS.  ``wait_until`` is how DJ Rob's nodes start an action on time: a
coarse sleep, then a short spin on the clock itself, so the action starts
within a fraction of a millisecond of the target unless the machine is
overloaded; ``realtime`` lifts the waiting thread to real-time scheduling
for the start so that a busy machine does not delay it.  ``true_time``
reads CLOCK_REALTIME by a raw system call, which libfaketime does not
intercept: the ground truth a test compares a faked process's actions
with.

The GIL and real-time threads: a real-time thread that needs the GIL
while a normal thread of its process holds it waits until that thread
runs, and real-time threads spinning on every core (robots starting at
one instant) keep it from running: the start comes late by the others'
spins (milliseconds).  ``wait_until(hold=...)`` therefore takes the GIL
``hold`` s before the target, while the cores are still free, and keeps
it to the target (``KeptGil``, ``pause``, ``turn`` and ``true_time`` never
release it).
"""

from __future__ import annotations

import ctypes
import ctypes.util
import os
import platform
import sys
import time
from typing import Callable, Optional

# SYS_clock_gettime by architecture (asm/unistd.h).
_SYS_CLOCK_GETTIME = {'x86_64': 228, 'aarch64': 113, 'i686': 265,
                      'armv7l': 263}
_CLOCK_REALTIME = 0


class _Timespec(ctypes.Structure):
    _fields_ = [('tv_sec', ctypes.c_long), ('tv_nsec', ctypes.c_long)]


# PyDLL: its calls keep the GIL (they are all short or meant to hold it).
_libc = ctypes.PyDLL(ctypes.util.find_library('c') or 'libc.so.6',
                     use_errno=True)
# The switch interval while a start keeps the GIL: long enough that no
# other thread of the process asks for the GIL before the start.
KEPT_INTERVAL = 1.0
_syscall_nr = _SYS_CLOCK_GETTIME.get(platform.machine())


def true_time() -> float:
    """The host's real CLOCK_REALTIME in s, bypassing libfaketime.

    Returns NaN on an architecture whose syscall number is not known here
    (never a silently faked value)."""
    if _syscall_nr is None:
        return float('nan')
    ts = _Timespec()
    if _libc.syscall(_syscall_nr, _CLOCK_REALTIME, ctypes.byref(ts)) != 0:
        return float('nan')
    return ts.tv_sec + ts.tv_nsec * 1e-9


class realtime:
    """Context manager: the calling thread runs SCHED_FIFO at
    ``priority`` inside the block (0: unchanged), so a busy machine does
    not delay a start.  ``ok`` says whether it was granted (it needs root
    or CAP_SYS_NICE / an rtprio limit); ``error`` says why not."""

    def __init__(self, priority: int) -> None:
        self.priority = priority
        self.ok = False
        self.error = '' if priority > 0 else 'not requested'
        self._saved: tuple[int, os.sched_param] | None = None

    def __enter__(self) -> 'realtime':
        if self.priority <= 0:
            return self
        try:
            self._saved = (os.sched_getscheduler(0), os.sched_getparam(0))
            os.sched_setscheduler(0, os.SCHED_FIFO,
                                  os.sched_param(self.priority))
            self.ok = True
        except (OSError, AttributeError) as e:
            self.error = str(e)
        return self

    def __exit__(self, *exc: object) -> None:
        if self.ok and self._saved is not None:
            policy, param = self._saved
            os.sched_setscheduler(0, policy, param)


def pause(seconds: float) -> None:
    """Sleep ``seconds`` without releasing the GIL (nanosleep)."""
    whole = int(seconds)
    ts = _Timespec(whole, int((seconds - whole) * 1e9))
    _libc.nanosleep(ctypes.byref(ts), None)


def turn() -> None:
    """Yield the CPU to threads of the same real-time priority without
    releasing the GIL (``os.sched_yield`` releases it)."""
    _libc.sched_yield()


class KeptGil:
    """While ``keep()`` is in force (until ``release()`` or the end of
    the ``with`` block), the other threads of the process do not ask the
    GIL's holder to hand it over: the switch interval is
    ``KEPT_INTERVAL``.  ``interval``: (get, set) of the switch interval,
    injected in tests."""

    def __init__(self, interval: tuple = (sys.getswitchinterval,
                                          sys.setswitchinterval)) -> None:
        self._get, self._set = interval
        self._saved: Optional[float] = None

    def keep(self) -> None:
        if self._saved is None:
            self._saved = self._get()
            self._set(max(self._saved, KEPT_INTERVAL))

    def release(self) -> None:
        if self._saved is not None:
            self._set(self._saved)
            self._saved = None

    def __enter__(self) -> 'KeptGil':
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()


def wait_until(now: Callable, target: float, spin: float = 0.003,
               stop: Callable = lambda: False, hold: float = 0.0,
               kept: Optional[KeptGil] = None, sleep: Callable = time.sleep,
               pause: Callable = pause, turn: Callable = turn,
               free_turn: Callable = os.sched_yield) -> float | None:
    """Block until ``now() >= target`` (both in the same clock, s).

    Sleeps (``sleep``, which releases the GIL) until ``max(hold, spin)``
    s before the target; from ``hold`` s before it keeps the GIL
    (``kept.keep()``, then ``pause`` until ``spin`` s before); then spins,
    yielding the CPU at each turn (``turn``; without ``kept``,
    ``free_turn``, which releases the GIL, so that start threads of one
    process take turns): several real-time threads spinning for the same
    instant (robots in unison) take turns on the cores instead of the
    first ones holding them past the target.  The caller releases
    ``kept`` once its start is done.  Returns how late it returned (s,
    >= 0), or None if ``stop()`` became true first.
    """
    ahead = max(hold, spin)
    while True:
        remaining = target - now()
        if remaining <= 0:
            return max(0.0, -remaining)
        if stop():
            return None
        if remaining > ahead:
            sleep(min(remaining - ahead, 0.1))
            continue
        if kept is not None:
            kept.keep()
        if remaining > spin:
            pause(min(remaining - spin, 0.1))
        else:
            (turn if kept is not None else free_turn)()
