"""A node's life: its start, its end on a config error or a master
restart, and its shutdown with its parent."""
import os
import signal
import sys
import threading

import rospy

from hri_sync.ros import master_watch, unique
from hri_sync.ros.lifeline import die_with_parent
from hri_sync.ros.params import ParamError
from hri_sync.ros.rpc_server import stop_serving_at_shutdown


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
