"""Node plumbing: ~params, polled waits and rospy.Time conversion."""
import math
import os
import signal
import sys
import threading
import time

import rospy
from std_msgs.msg import Header

from hri_sync.ros import master_watch, unique
from hri_sync.ros.lifeline import die_with_parent
from hri_sync.ros.rpc_server import stop_serving_at_shutdown
from hri_sync.wire.validate import Rejected, time_value


class ParamError(Exception):
    """A ~param that is missing or wrong."""


def param(name, default=None, kind=None, check=None, why=''):
    """Read private param ``~name``; convert with ``kind`` and validate.

    Raises ParamError naming the param when it is missing (no default),
    of the wrong type, or fails ``check``.
    """
    key = '~' + name
    if not rospy.has_param(key):
        if default is None:
            raise ParamError('required param %s is not set (%s)'
                             % (rospy.resolve_name(key), why or 'no default'))
        value = default
    else:
        value = rospy.get_param(key)
    if kind is not None:
        try:
            value = kind(value)
        except (TypeError, ValueError) as e:
            raise ParamError('param %s=%r is not a valid %s: %s'
                             % (rospy.resolve_name(key), value,
                                getattr(kind, '__name__', kind), e))
    if check is not None and not check(value):
        raise ParamError('param %s=%r is out of range: %s'
                         % (rospy.resolve_name(key), value, why))
    return value


def csv_list(value):
    """A list of names from a comma-separated string or a YAML list."""
    if isinstance(value, (list, tuple)):
        items = [str(v).strip() for v in value]
    else:
        items = [v.strip() for v in str(value).split(',')]
    return [v for v in items if v]


def positive(x):
    """True for a finite number > 0."""
    return math.isfinite(x) and x > 0


def _shutdown_in_a_thread(signum, _frame):
    """SIGTERM (a lifeline's, roslaunch's escalation): rospy's shutdown
    in a thread of its own.  rospy's handler runs it in the main thread
    at whatever line the signal interrupts; inside rospy's topic manager
    lock (a subscriber unregistering) its close_all then waits for that
    lock forever, and the node outlives its roslaunch (the control
    module in orphans_dance_off under load)."""
    threading.Thread(target=rospy.signal_shutdown, daemon=True,
                     args=('signal-%d' % signum,)).start()


def run_node(name, main, master_restart='exit'):
    """init_node, watch the master, then run ``main()``.

    A ParamError ends the node with a fatal message naming the param (exit
    status 2).  A restart of the ROS master (``master_watch``) is logged
    and, with ``master_restart='exit'``, shuts the node down with exit
    status ``master_watch.RESTART_EXIT`` (75) for roslaunch to respawn it;
    with 'warn' the node keeps running unregistered.  The node shuts down
    (SIGTERM, handled in a thread) when its parent, e.g. roslaunch, dies:
    no orphan nodes.
    A live node of the same resolved name (a second system launched into
    this one's namespace) ends the node before ``init_node`` with a
    message saying so (exit status ``unique.DUPLICATE_EXIT``), instead of
    ROS taking the name from the running node.
    """
    if master_restart not in ('exit', 'warn'):
        raise ValueError("master_restart must be 'exit' or 'warn', got %r"
                         % (master_restart,))
    die_with_parent(signal.SIGTERM)
    try:
        unique.check(unique.resolved_node_name(name, sys.argv))
    except unique.Duplicate as e:
        print('%s: %s' % (name, e), file=sys.stderr, flush=True)
        raise SystemExit(unique.DUPLICATE_EXIT)
    stop_serving_at_shutdown()
    rospy.init_node(name)
    signal.signal(signal.SIGTERM, _shutdown_in_a_thread)
    if 'libfaketime' in os.environ.get('LD_PRELOAD', ''):
        # Under libfaketime 0.9.10 (skewed_client) a timed thread join
        # spins: rospy's shutdown, after its hooks ran, would spin up to 5 s
        # a thread (skewed_client kills its client 3 s after a SIGINT).
        rospy.core._TIMEOUT_SHUTDOWN_JOIN = 0.0
    watch = master_watch.start(exit_on_restart=master_restart == 'exit')
    try:
        main()
    except ParamError as e:
        rospy.logfatal('%s: %s', rospy.get_name(), e)
        raise SystemExit(2)
    except rospy.ROSInterruptException:
        pass
    except Exception as e:
        if not (watch.restarted and watch.exit_on_restart):
            raise
        rospy.logwarn('%s stopped with %r after the master restart',
                      rospy.get_name(), e)
    if watch.restarted and watch.exit_on_restart:
        raise SystemExit(master_watch.RESTART_EXIT)


def init_checker(name):
    """``rospy.init_node`` for a process that does not run under
    ``run_node`` (a test's checker or helper node): its XML-RPC server
    stopped at shutdown (``rpc_server``) and its subscriptions checked
    (``master_watch.watch_links``)."""
    stop_serving_at_shutdown()
    rospy.init_node(name)
    master_watch.watch_links()


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


class StampError(ValueError):
    """A time that must not be published: not finite, not positive or
    beyond the last ROS time (rospy cannot serialise it, and a publisher
    that tries corrupts its link for good).  ``reason`` is the key of
    hri_sync.wire.validate."""

    def __init__(self, reason, message):
        super().__init__(message)
        self.reason = reason


def stamp(t):
    """A float of seconds as rospy.Time, validated first.

    None is the explicit "no time" (a zero time, for fields whose contract
    says 0 means unknown); a time that is not finite, not positive or not
    below 2**32 s raises StampError instead of going out.
    """
    if t is None:
        return rospy.Time()
    try:
        time_value(t, 'stamp')
    except Rejected as e:
        raise StampError(e.reason, str(e))
    return rospy.Time.from_sec(t)


def header(t, frame_id=''):
    """A std_msgs/Header whose stamp is ``stamp(t)`` (validated; None: a
    zero time); rospy fills in its seq."""
    return Header(stamp=stamp(t), frame_id=frame_id)


def secs(t):
    """A rospy.Time or Duration as float seconds."""
    return t.to_sec()
