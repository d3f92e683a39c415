"""Is the recorder connected?  No round before the bag can hold it.

A recorder (rosbag record) started beside the system subscribes to what it
records and connects to each publisher in its own time; on a loaded machine
that took seconds, and what a publisher sends before its connection is not
in the bag (a first round's captured samples, so verify_decisions could not
recompute the round).  Before its first round the control module asks the
master who publishes the recorder's topics, and each publisher (getBusInfo,
the slave API call that ``rosnode info`` makes) whether its connection to
the recorder is up: a publisher lists a subscriber once their handshake is
done, the subscriber lists it before.  rospy-free (XML-RPC).
"""
import xmlrpc.client

from hri_sync.ros.unique import TimeoutTransport


def unlinked(recorder, state, bus_info_of):
    """The (topic, publisher node) pairs, sorted, of the topics that
    ``recorder`` subscribes to, whose publisher has no connection to it.

    ``state``: the master's getSystemState [publishers, subscribers,
    services]; ``bus_info_of(node)``: the node's getBusInfo rows [id, peer,
    direction, transport, topic, connected, ...] (a publisher's peer is
    the subscriber's name), None when it does not answer.
    """
    publishers = {t: nodes for t, nodes in state[0]}
    topics = sorted(t for t, nodes in state[1] if recorder in nodes)
    info = {}
    missing = []
    for t in topics:
        for node in sorted(publishers.get(t, ())):
            if node == recorder:
                continue
            if node not in info:
                info[node] = bus_info_of(node) or []
            if not any(len(r) >= 6 and r[1] == recorder and r[2] == 'o'
                       and r[4] == t and r[5] for r in info[node]):
                missing.append((t, node))
    return missing


class RecorderLink:
    """Asks the master and the publishers whether the recorder node
    ``recorder`` (a resolved name) is connected to every publisher of what
    it records; ``missing()`` -> what is not, as a sentence (empty: all
    is).  ``call(method, *args)``: a master API call with a timeout
    (hri_sync.ros.master_watch.master_call; OSError on failure)."""

    def __init__(self, recorder, call, caller, timeout=2.0):
        self.recorder = recorder
        self.call = call
        self.caller = caller
        self.timeout = timeout

    def bus_info(self, node):
        """``node``'s getBusInfo rows; None if it cannot be asked."""
        try:
            code, _msg, uri = self.call('lookupNode', node)
            if code != 1:
                return None
            code, _msg, info = xmlrpc.client.ServerProxy(
                uri, transport=TimeoutTransport(self.timeout)).getBusInfo(
                    self.caller)
        except (OSError, xmlrpc.client.Error):
            return None
        return info if code == 1 else None

    def missing(self):
        try:
            if self.call('lookupNode', self.recorder)[0] != 1:
                return 'the recorder %s is not registered' % self.recorder
            code, msg, state = self.call('getSystemState')
            if code != 1:
                return 'the master refused getSystemState: %s' % msg
            gaps = unlinked(self.recorder, state, self.bus_info)
        except OSError as e:
            return 'the master cannot be reached (%s)' % e
        return 'no connection to the recorder %s: %s' % (
            self.recorder, ', '.join('%s from %s' % g for g in gaps)) \
            if gaps else ''
