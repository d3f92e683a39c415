"""Noticing that the ROS master restarted, for every node (``run_node``).

rospy registers a node's publishers, subscribers and services, and
roslaunch its params, with the master once.  A restarted master knows none
of them: connections already made keep working, but nothing can find the
node again (a service call, a late subscriber, ``rosnode``), and rospy
never registers again.  ``MasterWatch`` asks the master every second
whether it still knows this node at this node's URI.  Once it has seen the
node registered, a master that answers and does not know it has restarted;
so has one whose pid changed, even before this loop saw the node
registered, and even if it knows the node again (the link checks below may
register a subscription with the new master before this loop asks: the
node then looked registered for good, under load).  A master that does not
answer is only waited for.  Then the node says
so (logerr), writes its private params back to the new master (it took
them at start; ``keep_param`` updates them), and ends with exit status
``RESTART_EXIT`` so that roslaunch's ``respawn="true"`` starts it again,
registered with the new master; a node without respawn stays down, and
its log says the launch must be restarted.  A node that needs no
registration to do its work (the time server) may instead keep running,
unregistered, with ``run_node(..., master_restart='warn')``.  The same
loop connects a new subscription to a publisher that rospy's registration
race made it miss (``hri_sync.ros.links``).
"""
import http.client
import logging
import os
import threading
import time
import xmlrpc.client

import rosgraph
import rospy

from hri_sync.ros.links import LinkRepair
from hri_sync.ros.unique import TimeoutTransport

RESTART_EXIT = 75   # EX_TEMPFAIL: try again (roslaunch respawns the node)
PERIOD = 1.0        # s between two questions to the master
TIMEOUT = 10.0      # s a question may take (a loaded master answers late)
GRACE = 5.0         # s the node has to shut down before it is ended

_current = None     # the watch of this process, for keep_param


class MasterWatch:
    """Whether the master still knows node ``name`` at ``uri``.

    ``uri`` None: the first URI the master has for the node (a node
    watched from another process, scripts/lifeline --master-watch).
    ``lookup(name)`` returns the URI the master has for the node, or None
    if it does not know it, and raises OSError when the master does not
    answer; ``pid()`` the master's process id (for the log).  ``check``
    returns one of 'waiting' (not seen registered yet), 'ok',
    'unreachable', 'back' (answering again after 'unreachable') or
    'restarted'; ``reason`` then says what happened.
    """

    def __init__(self, name, uri, master_uri, lookup, pid):
        self.name = name
        self.uri = uri
        self.master_uri = master_uri
        self._lookup = lookup
        self._pid = pid
        self.seen = False
        self.master_pid = None
        self.unreachable = None   # why the master stopped answering
        self.restarted = False
        self.reason = ''

    def check(self):
        """Ask the master once (see the class docstring)."""
        if self.restarted:
            return 'restarted'
        try:
            known = self._lookup(self.name)
            pid = self._pid()
        except OSError as e:
            first = self.unreachable is None
            self.unreachable = str(e) or type(e).__name__
            return 'unreachable' if first else 'still_unreachable'
        was_unreachable = self.unreachable is not None
        self.unreachable = None
        if self.master_pid is None:
            self.master_pid = pid
        if self.uri is None and known:
            self.uri = known     # a node watched from outside: its URI
        same_master = pid == self.master_pid
        if known and known == self.uri and same_master:
            self.seen = True
            return 'back' if was_unreachable else 'ok'
        if not self.seen and same_master:
            return 'waiting'
        self.restarted = True
        what = 'lost its registrations' if same_master else \
            'restarted (pid %s, was %s)' % (pid, self.master_pid)
        if not known:
            has = ''
        elif known == self.uri:
            has = ' (but for a subscription the link checks registered since)'
        else:
            has = ' (it has %s under that name)' % known
        self.reason = (
            'the ROS master at %s %s and no longer knows %s at %s%s: its '
            'topics, services and params are gone'
            % (self.master_uri, what, self.name, self.uri, has))
        return 'restarted'


def master_call(caller_id, master_uri):
    """``call(method, *args)``: one master API call over XML-RPC with a
    timeout; its (code, msg, value), or OSError on failure."""
    proxy = xmlrpc.client.ServerProxy(master_uri,
                                      transport=TimeoutTransport(TIMEOUT))

    def call(method, *args):
        try:
            code, msg, value = getattr(proxy, method)(caller_id, *args)
        except (xmlrpc.client.Error, http.client.HTTPException,
                ValueError) as e:
            raise OSError('%s: %s' % (method, e))
        return code, msg, value
    return call


def _master_calls(caller_id, master_uri):
    """lookup and pid over XML-RPC with a timeout (OSError on failure)."""
    call = master_call(caller_id, master_uri)

    def lookup(name):
        code, _msg, value = call('lookupNode', name)
        return value if code == 1 else None

    def pid():
        code, msg, value = call('getPid')
        if code != 1:
            raise OSError('getPid: %s' % msg)
        return value
    return lookup, pid


def keep_param(name, value):
    """Set private param ``~name`` and keep it for a restarted master
    (e.g. the CM's next round number); a master that does not answer now
    is logged, and gets the value when it restarts."""
    if _current is not None:
        _current.params[name] = value
    try:
        rospy.set_param('~' + name, value)
    except (OSError, xmlrpc.client.Error) as e:
        rospy.logwarn('could not set %s=%r on the master: %s',
                      rospy.resolve_name('~' + name), value, e)


class _Runner:
    """The watch's thread in a rospy node."""

    def __init__(self, exit_on_restart):
        self.exit_on_restart = exit_on_restart
        name = rospy.get_name()
        master_uri = rosgraph.get_master_uri()
        self.watch = MasterWatch(name, rospy.get_node_uri(), master_uri,
                                 *_master_calls(name, master_uri))
        self.call = master_call(name, master_uri)
        self.links = LinkRepair(self.call)
        try:
            params = rospy.get_param('~')
        except (KeyError, OSError):
            params = {}
        self.params = params if isinstance(params, dict) else {}

    @property
    def restarted(self):
        """True once the master restarted."""
        return self.watch.restarted

    def run(self):
        while not rospy.is_shutdown():
            state = self.watch.check()
            if rospy.is_shutdown():
                return
            if state == 'unreachable':
                rospy.logwarn('the ROS master at %s does not answer (%s); '
                              'waiting for it', self.watch.master_uri,
                              self.watch.unreachable)
            elif state == 'back':
                rospy.loginfo('the ROS master at %s answers again and '
                              'still knows %s', self.watch.master_uri,
                              self.watch.name)
            elif state == 'restarted':
                self._restarted()
                return
            if self.watch.seen and not self.watch.unreachable:
                self.links.check()
            time.sleep(PERIOD)

    def _restarted(self):
        if not self.exit_on_restart:
            rospy.logerr('%s; %s keeps running unregistered (rosnode does '
                         'not list it; restart it to register it again)',
                         self.watch.reason, self.watch.name)
            return
        restored = self._restore_params()
        rospy.logerr('%s; %s exits (status %d) so that roslaunch '
                     '(respawn="true") starts it again, registered with the '
                     'new master%s; without respawn, restart the launch',
                     self.watch.reason, self.watch.name, RESTART_EXIT,
                     restored)
        threading.Thread(target=self._end_after_grace, daemon=True).start()
        rospy.signal_shutdown('the ROS master restarted')

    def _restore_params(self):
        """Write the private params back to the new master, with the
        watch's timeout: the node must exit even if the master, just
        started on a busy machine, does not answer (rospy.set_param
        would wait for ever)."""
        if not self.params:
            return ''
        try:
            code, msg, _ = self.call('setParam', rospy.resolve_name('~'),
                                     self.params)
        except OSError as e:
            return ' (could not write its params back: %s)' % e
        if code != 1:
            return ' (could not write its params back: %s)' % msg
        return ' (its private params written back)'

    @staticmethod
    def _end_after_grace():
        # rospy's shutdown can hang (under libfaketime, a timed join).
        time.sleep(GRACE)
        logging.shutdown()
        os._exit(RESTART_EXIT)


def start(exit_on_restart=True):
    """Start watching the master for this (initialised) rospy node; returns
    the runner (``restarted`` tells the node why it stops)."""
    global _current
    runner = _Runner(exit_on_restart)
    _current = runner
    threading.Thread(target=runner.run, daemon=True,
                     name='master_watch').start()
    return runner


def watch_links(period=PERIOD):
    """For a rospy process that does not run under ``run_node`` (a test's
    checker): the subscription checks of ``hri_sync.ros.links``, in a
    thread of their own, every ``period`` s."""
    name = rospy.get_name()
    repair = LinkRepair(master_call(name, rosgraph.get_master_uri()))

    def run():
        while not rospy.is_shutdown():
            repair.check()
            time.sleep(period)
    threading.Thread(target=run, daemon=True, name='links').start()
