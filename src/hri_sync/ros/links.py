"""Subscriptions that missed a publisher: found and connected.

rospy connects a new subscription to the publishers in two lists: the one
the master returns to registerSubscriber, and the one in each
publisherUpdate the master sends when a publisher registers.  Its
registration thread queues both and keeps only the last one queued for a
topic.  When a publisher registers while the registerSubscriber answer is
still on its way (a loaded machine), the master's update, which has the
publisher, can be queued before the answer, which does not, and is
dropped: the subscriber never connects to that publisher.  Seen in
``diagnostics_round`` under load: a DPM never heard its CPM's latched
``clock_state``, though both ran for 16 s.

So, for ``SETTLE`` s after a subscription appears, the node asks the master
once a check for the topic's publishers (registerSubscriber again, which
the master treats as the same registration, as rospy itself does), and
hands rospy the publishers it had no connection to at two checks in a row
(not one: a connection may be under way), as the master's publisherUpdate
would (its own node API call).  A subscription found complete at a check
a second or more after it appeared is not asked about again.
"""
import time
import xmlrpc.client

import rospy
from rospy.impl.registration import get_topic_manager

from hri_sync.ros.unique import TimeoutTransport

SETTLE = 30.0   # s after a subscription appears that it is checked
FIRST = 1.0     # s after it appears that a complete check ends its checks


class LinkCheck:
    """Which subscriptions to ask about and which publishers to hand over
    (no ROS; times in s from any monotonic clock)."""

    def __init__(self, settle=SETTLE, first=FIRST):
        self.settle = settle
        self.first = first
        self.seen = {}        # topic -> when it appeared
        self.done = set()     # topics found complete
        self.missing = {}     # topic -> publishers missing at the last check
        self.repairs = 0      # publishers handed over

    def due(self, topics, now):
        """The topics of ``topics`` (this node's subscriptions now) to ask
        the master about; topics no longer subscribed are forgotten, so a
        subscription made again is checked again."""
        for t in list(self.seen):
            if t not in topics:
                del self.seen[t]
                self.done.discard(t)
                self.missing.pop(t, None)
        for t in topics:
            self.seen.setdefault(t, now)
        return sorted(t for t in topics if t not in self.done
                      and now - self.seen[t] < self.settle)

    def repair(self, topic, publishers, connected, now):
        """The publishers of ``topic`` (the master's list) to hand over:
        not in ``connected`` at this check nor at the last one."""
        missing = set(publishers) - set(connected)
        before = self.missing.get(topic, set())
        self.missing[topic] = missing
        if not missing and now - self.seen.get(topic, now) >= self.first:
            self.done.add(topic)
        lost = sorted(missing & before)
        self.repairs += len(lost)
        return lost


class LinkRepair:
    """The check above for this rospy node: ``check()`` once a period
    (master_watch's loop calls it).  ``call(method, *args)``: a master API
    call with a timeout (OSError on failure)."""

    def __init__(self, call):
        self.call = call
        self.core = LinkCheck()

    def check(self):
        tm = get_topic_manager()
        topics = dict(tm.get_subscriptions())
        uri = rospy.get_node_uri()
        for topic in self.core.due(topics, time.monotonic()):
            try:
                code, _msg, publishers = self.call(
                    'registerSubscriber', topic, topics[topic], uri)
            except OSError:
                return              # the master watch says why
            impl = tm.get_subscriber_impl(topic)
            if impl is None:        # unsubscribed meanwhile: undo the call
                self.unregister(topic, uri)
                continue
            if code != 1:
                continue
            lost = self.core.repair(
                topic, publishers,
                [p for p in publishers if impl.has_connection(p)],
                time.monotonic())
            if lost:
                self.hand_over(topic, publishers, lost, uri)

    def unregister(self, topic, uri):
        try:
            self.call('unregisterSubscriber', topic, uri)
        except OSError:
            pass                    # the master watch says why

    @staticmethod
    def hand_over(topic, publishers, lost, uri):
        rospy.logwarn('%s: not connected to %s on %s after two checks (a '
                      'publisher update lost to rospy\'s registration race): '
                      'connecting', rospy.get_name(), ', '.join(lost), topic)
        try:
            xmlrpc.client.ServerProxy(
                uri, transport=TimeoutTransport(10.0)).publisherUpdate(
                '/master', topic, publishers)
        except (OSError, xmlrpc.client.Error) as e:
            rospy.logerr('%s: could not hand %s over for %s: %s',
                         rospy.get_name(), ', '.join(lost), topic, e)
