"""Polled waits and delayed calls that work under libfaketime."""
import threading
import time

import rospy


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
