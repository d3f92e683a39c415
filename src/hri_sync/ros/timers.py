"""Polled waits and delayed calls that work under libfaketime."""
import threading
import time

import rospy

from hri_sync.clock.truth import realtime
from hri_sync.ros.params import param


def wait_for(predicate, timeout, poll=0.005):
    """Poll ``predicate`` until true or ``timeout`` s; returns its value.

    Timed waits on locks and events (threading.Timer, Event.wait(t)) hang
    under libfaketime; plain sleeps work, so every wait here polls.
    """
    deadline = time.monotonic() + timeout
    while not predicate():
        if time.monotonic() >= deadline or rospy.is_shutdown():
            return predicate()
        time.sleep(poll)
    return True


def after(delay, callback, *args):
    """Call ``callback(*args)`` in a thread after ``delay`` s (a
    sleep-based threading.Timer, which would hang under libfaketime).

    Nothing bounds how late the call comes: on a loaded machine, ms to
    (in principle) any delay.  Use it only for what may come late: never
    to define a capture window (windows are their timestamps; the DPM's
    wake-up at a window start only records ``wake_lateness``)."""
    def run():
        if delay > 0:
            time.sleep(delay)
        if not rospy.is_shutdown():
            callback(*args)
    threading.Thread(target=run, daemon=True).start()


def start_timing(client_id, late):
    """``(~start_spin, ~realtime_priority)`` of a node that starts things
    at global times (``clock.truth.wait_until`` spins that long on the
    clock before a start, under that real-time priority); a warning
    'real-time scheduling refused ...: on a busy machine ' + ``late`` when
    the priority cannot be had."""
    spin = param('start_spin', 0.01, float, lambda x: 0 <= x < 1,
                 's spent spinning on the clock before a start, within '
                 '[0, 1)')
    priority = param('realtime_priority', 10, int, lambda p: 0 <= p <= 99,
                     '0 (off) .. 99')
    with realtime(priority) as rt:
        if priority and not rt.ok:
            rospy.logwarn('%s: real-time scheduling refused (%s): on a '
                          'busy machine %s', client_id, rt.error, late)
    return spin, priority
