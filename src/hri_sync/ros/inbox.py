"""Inbox: messages accepted only from their rightful sender, and valid.

A node makes one ``Inbox`` and subscribes through it.  Each message is
admitted in three steps, and counted per (topic, reason) when it is not:

1. the sender: the publishing node named in the connection header
   (``msg._connection_header['callerid']``) must be one that owns the
   topic in the protocol (``Senders``: only the CM starts rounds and sends
   capture orders, only client X's CPM ACKs for X and orders X's DPM,
   only X's DPM (or its CPM, for a late window) reports X's result, only
   X's sensor feeds X's DPM, only the DM decides);
2. the content: ``hri_sync.wire.validate`` against the receiver's
   ``Context`` (its global now, the round in progress);
3. the callback: an exception is caught, logged with its traceback once
   (then throttled, with a count) and counted; it never kills the node.

A rejection is logged with its topic, sender, reason key and message,
throttled per (topic, reason), and counted in ``rejected``;
``summary()`` gives the counts for /diagnostics.  See docs/reliability.md
for what this does and does not protect against: ROS 1 has no
authentication, a caller id is whatever the publisher says it is.
"""
import dataclasses
import time
import traceback
from collections import Counter

import genpy
import rospy

from hri_sync.ros.names import system_namespace
from hri_sync.wire import validate
from hri_sync.wire.validate import Context, Rejected

# Who may publish what: a role's node names, relative to the system
# namespace (hri_sync.ros.names); '{client}' is the client id.
DEFAULT_ROLES = {
    'cm': ['control_module'],
    'dm': ['decision_module'],
    # A client's CPM: client.launch's, or a node that is the whole client
    # (turtlebot_gesture as dj_rob, music_player as music, or as robot in
    # the client's namespace: robots.launch's robot1/robot).
    'cpm': ['{client}/cpm', '{client}', '{client}/robot'],
    'dpm': ['{client}/dpm'],
    # A client's ClientResult: its DPM's, or its CPM's for a late window.
    'result': ['{client}/dpm', '{client}/cpm', '{client}'],
    'sensor': ['{client}/sensor', '{client}/tracker'],
    'base': ['kobuki_sim', 'mobile_base', 'mobile_base_nodelet_manager',
             '{client}/kobuki_sim'],
    'robot': ['dj_rob'],
}


class Senders:
    """The node names that own each role, per client.

    ``config`` (the ``~senders`` param) overrides ``DEFAULT_ROLES``: a
    role maps to a name or a list of names, ``'{client}'`` standing for
    the client id; ``clients`` maps a client id to its own overrides:

        {cm: control_module, clients: {dj_rob: {cpm: /lab1/dj_rob}}}

    A relative name is in the system namespace ``ns`` (a CM in /lab2/
    is not /lab1/'s CM); a global one is taken as it is.
    """

    def __init__(self, config=None, ns='/'):
        if not (isinstance(ns, str) and ns.startswith('/')):
            raise ValueError('senders: the system namespace must be global,'
                             ' got %r' % (ns,))
        self.ns = ns if ns.endswith('/') else ns + '/'
        config = dict(config or {})
        self.clients = {c: self._roles(r)
                        for c, r in dict(config.pop('clients', {})).items()}
        self.roles = dict(DEFAULT_ROLES)
        self.roles.update(self._roles(config))

    @staticmethod
    def _roles(config):
        out = {}
        for role, names in dict(config).items():
            names = [names] if isinstance(names, str) else list(names)
            if not names or not all(
                    isinstance(n, str) and n and n.strip('/') and
                    not n.startswith('~') for n in names):
                raise ValueError('senders: role %r needs node names (global'
                                 ', or relative to the system namespace),'
                                 ' got %r' % (role, names))
            out[role] = names
        return out

    def names(self, role, client=None):
        """The resolved node names that may act as ``role`` (of
        ``client``); ValueError for an unknown role."""
        own = self.clients.get(client, {})
        if role in own:
            patterns = own[role]
        elif role in self.roles:
            patterns = self.roles[role]
        else:
            raise ValueError('senders: unknown role %r (known: %s)'
                             % (role, ', '.join(sorted(self.roles))))
        return frozenset(self._resolve(p.replace('{client}', client or ''))
                         for p in patterns)

    def _resolve(self, name):
        return name if name.startswith('/') else self.ns + name

    @classmethod
    def from_params(cls):
        """From ``~senders``, else a ``senders`` param up the namespace;
        relative names in this node's system namespace."""
        key = '~senders' if rospy.has_param('~senders') else \
            rospy.search_param('senders')
        return cls(rospy.get_param(key) if key else None,
                   system_namespace())


def plain(value):
    """A message as plain values: dicts of fields, times and durations as
    float seconds, arrays as lists."""
    if isinstance(value, genpy.TVal):
        return value.to_sec()
    if isinstance(value, genpy.Message):
        return {s: plain(getattr(value, s)) for s in value.__slots__}
    if isinstance(value, (list, tuple)):
        return [plain(v) for v in value]
    return value


class Throttle:
    """At most one log line per key and ``period`` (on ``clock``)."""

    def __init__(self, period=10.0, clock=time.monotonic):
        self.period = period
        self.clock = clock
        self.last = {}

    def due(self, key):
        """True (and restart the period) if ``key`` may log now."""
        now = self.clock()
        if key in self.last and now - self.last[key] < self.period:
            return False
        self.last[key] = now
        return True


class Inbox:
    """One node's subscriptions, each checked by sender and content.

    ``rejected`` counts (topic, reason); ``accepted`` counts topics;
    ``errors`` counts (topic, exception type) of callbacks that raised.
    """

    def __init__(self, senders=None, log_period=10.0, clock=time.monotonic):
        self.senders = senders if senders is not None else \
            Senders.from_params()
        self.rejected = Counter()
        self.accepted = Counter()
        self.errors = Counter()
        self.throttle = Throttle(log_period, clock)

    def subscribe(self, topic, msg_class, callback, sender, client=None,
                  context=Context, check=True, **kwargs):
        """rospy.Subscriber whose ``callback(msg)`` sees only admitted
        messages.

        ``sender``: the role that owns the topic (``'cm'``), or None for
        a topic any node may publish on.  ``client``: the client whose
        role it is, a fixed id or a function of the message (``lambda m:
        m.client_id``: only X's CPM ACKs for X).  ``context()`` gives the
        ``validate.Context`` to judge each message against (its ``client``
        is set to a fixed ``client`` when it has none); ``check=False``
        skips the content check.  Other keyword arguments go to
        rospy.Subscriber.
        """
        topic = rospy.resolve_name(topic)
        if check and msg_class._type not in validate.VALIDATORS:
            raise ValueError('no validator for %s (topic %s)'
                             % (msg_class._type, topic))
        if sender is not None:
            self.senders.names(sender)      # an unknown role fails now
        admit = self.gate(topic, msg_class._type, sender, client, context,
                          check)

        def on_message(msg):
            if admit(msg):
                self.call(topic, callback, msg)
        return rospy.Subscriber(topic, msg_class, on_message, **kwargs)

    def gate(self, topic, msg_type, sender, client, context, check):
        """The admission test of one subscription: ``admit(msg)`` -> bool
        (rejections logged and counted)."""
        def admit(msg):
            caller = getattr(msg, '_connection_header', {}).get(
                'callerid', '')
            who = client(msg) if callable(client) else client
            try:
                if sender is not None:
                    allowed = self.senders.names(sender, who)
                    if caller not in allowed:
                        raise Rejected(
                            'wrong_sender', '%s may be published only by %s'
                            % (topic, ' or '.join(sorted(allowed))))
                if check:
                    ctx = context()
                    if ctx.client is None and isinstance(client, str):
                        ctx = dataclasses.replace(ctx, client=client)
                    validate.check(msg_type, plain(msg), ctx)
            except Rejected as e:
                self.reject(topic, caller, e)
                return False
            self.accepted[topic] += 1
            return True
        return admit

    def reject(self, topic, caller, error):
        """Count a rejection and log it (throttled per topic and reason)."""
        key = (topic, error.reason)
        self.rejected[key] += 1
        if self.throttle.due(key):
            rospy.logwarn('%s: message on %s from %s rejected (%s): %s; '
                          '%d rejected so far for this reason',
                          rospy.get_name(), topic, caller or 'an unknown '
                          'sender', error.reason, error, self.rejected[key])

    def call(self, topic, callback, msg):
        """Run a callback; an exception is logged and counted, not raised."""
        try:
            callback(msg)
        except Exception as e:
            key = (topic, type(e).__name__)
            self.errors[key] += 1
            if self.errors[key] == 1:
                rospy.logerr('%s: callback on %s failed: %r (traceback '
                             'logged once, then counted)\n%s',
                             rospy.get_name(), topic, e,
                             traceback.format_exc())
            elif self.throttle.due(('error',) + key):
                rospy.logerr('%s: callback on %s failed again: %r; %d '
                             'failures of this kind', rospy.get_name(),
                             topic, e, self.errors[key])

    def summary(self):
        """Counts for /diagnostics: {'<topic> <reason>': n}, the accepted
        ones as '<topic> accepted', callback errors as '<topic>
        callback_error <Type>'."""
        out = {}     # dict(): a copy, as callbacks count meanwhile
        for topic, n in dict(self.accepted).items():
            out['%s accepted' % topic] = n
        for (topic, reason), n in dict(self.rejected).items():
            out['%s %s' % (topic, reason)] = n
        for (topic, kind), n in dict(self.errors).items():
            out['%s callback_error %s' % (topic, kind)] = n
        return dict(sorted(out.items()))
