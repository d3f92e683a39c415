"""One node per name: refuse to start beside a live node of the same name.

ROS 1 lets a new node take a name over: the master tells the running one
to shut down.  A second system launched into the namespace of a running
one (``/lab1`` twice) would so silently kill the first system's nodes
one by one and mix the two systems' rounds.  Before ``init_node``, a node
asks the master whether its resolved name is registered and, if so,
pings that node's XML-RPC API (``getPid``): a node that answers is alive,
and the new one exits with ``Duplicate``'s message instead.  A name whose
node does not answer (it died, or its machine is gone) is taken over as
ROS would.  rospy-free (rosgraph only), so that the ``lifeline`` prefix
checks rosbag, rostopic and the C++ tracker too.
"""
import os
import xmlrpc.client

import rosgraph
import rosgraph.names

from hri_sync.ros.names import system_namespace_of

DUPLICATE_EXIT = 3      # the exit status of a node refused as a duplicate


class Duplicate(Exception):
    """A live node already has this node's name."""


def resolved_node_name(default, argv, environ=os.environ):
    """The name a node started with ``argv`` gets: ``__name:=`` (else
    ``default``) in ``__ns:=`` (else ROS_NAMESPACE, else /)."""
    name, ns = default, None
    for arg in argv:
        if arg.startswith('__name:='):
            name = arg[len('__name:='):]
        elif arg.startswith('__ns:='):
            ns = arg[len('__ns:='):]
    if ns is None:
        ns = environ.get('ROS_NAMESPACE', '/')
    if name.startswith('/'):
        return name
    return rosgraph.names.ns_join(rosgraph.names.make_global_ns(ns), name)


def live_duplicate(name, lookup, ping):
    """(uri, pid) of a live node registered as ``name``, else None.

    ``lookup(name)`` -> the registered XML-RPC URI or None;
    ``ping(uri)`` -> the pid it reports, None when it does not answer.
    """
    uri = lookup(name)
    if not uri:
        return None
    pid = ping(uri)
    return None if pid is None else (uri, pid)


def message(name, uri, pid, client_id=None):
    """The refusal, naming the system namespace and the live node."""
    ns = system_namespace_of(rosgraph.names.namespace(name), client_id)
    return ('a system already runs in %s: node %s is alive (pid %d at %s); '
            'use another namespace (<group ns="...">) or stop that system'
            ' first' % (ns, name, pid, uri))


class TimeoutTransport(xmlrpc.client.Transport):
    """An XML-RPC transport whose connections give up after ``timeout``
    s (a node or master that does not answer)."""

    def __init__(self, timeout):
        super().__init__()
        self.timeout = timeout

    def make_connection(self, host):
        conn = super().make_connection(host)
        conn.timeout = self.timeout
        return conn


def live_node(name, timeout=3.0, caller='/hri_sync_unique_check'):
    """(uri, pid) of a live node registered as ``name`` on this process's
    master, else None; OSError or rosgraph.MasterException when the master
    cannot be reached."""
    master = rosgraph.Master(caller)

    def lookup(n):
        try:
            return master.lookupNode(n)
        except rosgraph.MasterError:     # not registered
            return None

    def ping(uri):
        try:
            code, _, pid = xmlrpc.client.ServerProxy(
                uri, transport=TimeoutTransport(timeout)).getPid(caller)
        except (OSError, xmlrpc.client.Error):
            return None
        return pid if code == 1 else None

    return live_duplicate(name, lookup, ping)


def node_pid(name, timeout=3.0):
    """The pid of live node ``name``; None when it is gone (or the master
    cannot be reached)."""
    try:
        found = live_node(name, timeout)
    except (OSError, rosgraph.MasterException):
        return None
    return found[1] if found else None


def check(name, timeout=3.0):
    """Raise ``Duplicate`` if a live node is registered as ``name`` on
    this process's master; nothing if the master cannot be reached (the
    node's own start waits for it)."""
    try:
        found = live_node(name, timeout)
    except (OSError, rosgraph.MasterException):
        return
    if found:
        try:
            client_id = rosgraph.Master('/hri_sync_unique_check').getParam(
                name + '/client_id')
        except (OSError, rosgraph.MasterException):
            client_id = None
        raise Duplicate(message(name, found[0], found[1],
                                client_id if isinstance(client_id, str)
                                else None))
