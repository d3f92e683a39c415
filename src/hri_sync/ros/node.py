"""A node's life: its start, its end on a config error or a master
restart, and its shutdown with its parent."""
import hashlib
import json
import os
import signal
import socket
import sys
import threading
import time

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


CONFIG_EXIT = 2         # the exit status of a node with a config error


def _launcher():
    """'host:pid' of the roslaunch (or rostest) that started this
    process, or None when its parent is not one (rosrun, a shell)."""
    ppid = os.getppid()
    try:
        with open('/proc/%d/cmdline' % ppid, 'rb') as f:
            argv = f.read().split(b'\0')[:2]
    except OSError:
        return None
    if not any(os.path.basename(a) in (b'roslaunch', b'rostest')
               for a in argv):
        return None
    return '%s:%d' % (socket.gethostname(), ppid)


def _config(node):
    """A digest of the params under ``node`` (its ~params) but the
    config error mark."""
    try:
        params = rospy.get_param(node, {})
    except Exception:       # no master: nothing to compare
        return ''
    if isinstance(params, dict):
        params.pop('config_error', None)
    return hashlib.sha1(json.dumps(params, sort_keys=True,
                                   default=str).encode()).hexdigest()


def _stay_down(node):
    """After a config error roslaunch respawns the node with the same
    params: that copy stays down, says so once and waits until its
    ~params change (then it starts) or its roslaunch stops it."""
    mark = node + '/config_error'
    launcher = _launcher()
    try:
        seen = rospy.get_param(mark, None) if launcher else None
    except Exception:       # no master: the node's start will say so
        return
    config = _config(node)
    if seen != '%s %s' % (launcher, config):
        return
    print('%s stays down after its config error (above): correct its '
          'params, or the launch file, and launch again' % node,
          file=sys.stderr, flush=True)
    try:
        while _config(node) == config:
            time.sleep(1.0)
    except KeyboardInterrupt:
        raise SystemExit(CONFIG_EXIT)


def _mark_config_error(node):
    """Mark a config error for a copy respawned by this node's
    roslaunch (``_stay_down``)."""
    launcher = _launcher()
    if launcher:
        rospy.set_param(node + '/config_error',
                        '%s %s' % (launcher, _config(node)))


def run_node(name, main, master_restart='exit'):
    """init_node, watch the master, then run ``main()``.

    A ParamError (a config error) ends the node with one fatal message
    naming the param (exit status ``CONFIG_EXIT``); a copy its roslaunch
    respawns with the same params stays down (``_stay_down``).  A restart
    of the ROS master (``master_watch``) is logged and, with
    ``master_restart='exit'``, shuts the node down with exit status
    ``master_watch.RESTART_EXIT`` (75) for roslaunch to respawn it; with
    'warn' the node keeps running unregistered.  The node shuts down
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
    node = unique.resolved_node_name(name, sys.argv)
    try:
        unique.check(node)
    except unique.Duplicate as e:
        print('%s: %s' % (name, e), file=sys.stderr, flush=True)
        raise SystemExit(unique.DUPLICATE_EXIT)
    _stay_down(node)
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
        _mark_config_error(node)
        raise SystemExit(CONFIG_EXIT)
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
