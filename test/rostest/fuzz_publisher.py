#!/usr/bin/python3
"""Publishes seeded random-field messages on every subscribed topic.

    rosrun hri_sync fuzz_publisher.py _seed:=1 _count:=2000 _rate:=400

Finds the topics the running nodes subscribe to (the master's system
state, less ~exclude and this node's own), and publishes ~count messages
of each topic's type, round-robin, at ~rate messages per second in all.
Every field is random, nested messages' too (a std_msgs/Header's seq,
stamp and frame_id), by its type and name: NaN, infinities, huge and
negative numbers; times at 0, near and beyond the last ROS time, with
nanoseconds past 1e9, far in the past and future, or near now; rounds
0, past, current (from /round_status), future and 2**32 - 1; empty, very
long and non-ASCII strings and arrays next to plausible client ids,
statuses and values, so both the boundary checks and the code behind
them are exercised.  Fixed-length arrays keep their length (the wire
format has no other), and a message that rospy cannot serialise is
drawn again (counted), so the fuzzer never corrupts its own links.

~impersonate: publish each topic under its protocol owner's caller id
(hri_sync.ros.inbox.Senders, as any ROS 1 node can claim any caller id),
so that checks behind the sender check are reached too.

Prints one JSON line at the end: messages per topic, redraws, seed.
"""
import io
import json
import math
import random
import re
import sys
import time

import rosgraph
import roslib.message
import rospy

from hri_sync.ros.inbox import Senders
from hri_sync.ros.node import init_checker

EXCLUDE = ('/rosout', '/rosout_agg', '/clock', '/tf', '/tf_static')
CLIENTS = ('left', 'right', 'dj_rob', 'music', 'skeleton', 'imu', 'audio',
           'camera', 'joints')
WORDS = {
    'status': ('ok', 'partial', 'no_data', 'late', 'error'),
    'outcome': ('winner', 'no_winner', 'tie', 'aborted'),
    'state': ('syncing', 'capturing', 'aborted'),
    'action': ('dance', 'music'),
    'frame_id': ('sensor', 'odom', 'base_footprint'),
    'child_frame_id': ('base_footprint',),
    'key': ('error', 'reason', 'unstamped_total'),
    'encoding': ('rgb8', 'bgr8', 'mono8', '16UC1', '32FC1'),
}
PLAUSIBLE = {           # name: (low, high) of a plausible value
    'str_aft': (0.0, 3.0), 'dur': (0.1, 10.0), 'offset': (-2.0, 2.0),
    'uncertainty': (0.0, 0.01), 'drift': (-1e-3, 1e-3),
    'coverage': (0.0, 1.0), 'value': (0.0, 10.0), 'bpm': (60.0, 180.0),
    'first_frame_offset': (-0.1, 0.1), 'wake_lateness': (-0.01, 0.05),
    'confidence': (0.0, 1.0), 'x': (-3.0, 3.0), 'y': (-3.0, 3.0),
    'z': (-3.0, 3.0), 'w': (-1.0, 1.0), 'scores': (0.0, 10.0),
}
INT_RANGES = {
    'int8': (-2 ** 7, 2 ** 7 - 1), 'uint8': (0, 2 ** 8 - 1),
    'byte': (-2 ** 7, 2 ** 7 - 1), 'char': (0, 2 ** 8 - 1),
    'int16': (-2 ** 15, 2 ** 15 - 1), 'uint16': (0, 2 ** 16 - 1),
    'int32': (-2 ** 31, 2 ** 31 - 1), 'uint32': (0, 2 ** 32 - 1),
    'int64': (-2 ** 63, 2 ** 63 - 1), 'uint64': (0, 2 ** 64 - 1),
}
FLOAT_MAX = {'float32': 3.4e38, 'float64': 1.7e308}
ARRAY = re.compile(r'^(.+)\[(\d*)\]$')


class Fuzzer:
    """Random messages; ``bad`` is the share of fields drawn extreme."""

    def __init__(self, rng, clock=time.time, bad=0.3, long=65536):
        self.rng = rng
        self.clock = clock
        self.bad = bad
        self.long = long
        self.round = 1

    def message(self, msg_class):
        """A message of ``msg_class`` with every field drawn."""
        msg = msg_class()
        for name, kind in zip(msg.__slots__, msg._slot_types):
            setattr(msg, name, self.value(name, kind))
        return msg

    def extreme(self):
        return self.rng.random() < self.bad

    def value(self, name, kind):
        m = ARRAY.match(kind)
        if m:
            return self.array(name, m.group(1), m.group(2))
        if kind in ('time', 'duration'):
            return self.time(kind)
        if kind == 'bool':
            return self.rng.random() < 0.5
        if kind in INT_RANGES:
            return self.integer(name, kind)
        if kind in FLOAT_MAX:
            return self.real(name, kind)
        if kind == 'string':
            return self.string(name)
        return self.message(roslib.message.get_message_class(kind))

    def array(self, name, kind, length):
        if length:
            n = int(length)
        else:
            # Long arrays of numbers; of strings and messages, shorter.
            long = (1000, 20000) if kind in INT_RANGES or \
                kind in FLOAT_MAX or kind == 'bool' else (100, 300)
            r = self.rng.random()
            n = (0 if r < 0.15 else self.rng.randint(*long)
                 if r < 0.25 else self.rng.randint(1, 4))
        if kind == 'string' and name in ('clients', 'acked', 'refused',
                                         'missing') and not self.extreme():
            return self.rng.sample(CLIENTS, self.rng.randint(0, 4))
        if kind in ('uint8', 'char'):
            return bytes(self.rng.randrange(256) for _ in range(n))
        return [self.value(name, kind) for _ in range(n)]

    def time(self, kind):
        """A rospy.Time or Duration, possibly non-canonical."""
        cls = rospy.Time if kind == 'time' else rospy.Duration
        now = self.clock()
        if not self.extreme():
            return cls.from_sec(now + self.rng.uniform(-5.0, 5.0)
                                if kind == 'time'
                                else self.rng.uniform(0.0, 10.0))
        top = 2 ** 32 - 1 if kind == 'time' else 2 ** 31 - 1
        low = 0 if kind == 'time' else -2 ** 31
        secs = self.rng.choice((
            0, 1, top, top - 5, 4294967290, int(now + 1e6),
            int(now - 1e6), int(now) + 3600, self.rng.randint(low, top)))
        t = cls(max(low, min(top, secs)))
        # Nanoseconds past 1e9: rospy does not canonicalise what it reads.
        t.nsecs = self.rng.choice((0, 999999999, 10 ** 9,
                                   2 ** 31 - 1 if kind != 'time'
                                   else 2 ** 32 - 1))
        return t

    def integer(self, name, kind):
        lo, hi = INT_RANGES[kind]
        if name == 'round':
            r = self.round
            return max(lo, min(hi, self.rng.choice((
                0, 1, r - 1, r, r, r + 1, r + 2, r + 1000, hi))))
        if self.extreme():
            return self.rng.choice((lo, hi, 0, self.rng.randint(lo, hi)))
        return self.rng.randint(max(lo, 0), min(hi, 20))

    def real(self, name, kind):
        if not self.extreme():
            lo, hi = PLAUSIBLE.get(name, (-10.0, 10.0))
            return self.rng.uniform(lo, hi)
        big = FLOAT_MAX[kind]
        return self.rng.choice((
            math.nan, math.inf, -math.inf, 0.0, -0.0, big, -big, 1e-300,
            -1.0, 4294967290.0, 1e6, self.rng.uniform(-1e9, 1e9)))

    def string(self, name):
        if not self.extreme():
            if name == 'client_id':
                return self.rng.choice(CLIENTS)
            if name in WORDS:
                return self.rng.choice(WORDS[name])
            return 'fuzz %d' % self.rng.randrange(1000)
        return self.rng.choice((
            '', 'x' * self.long, '\u00e9\u2603\U0001f600', 'a/b c',
            '../../etc', '%s%n%d', 'left\nright', 'nan', '-1',
            ''.join(chr(self.rng.randrange(32, 0x2fff))
                    for _ in range(self.rng.randint(1, 50)))))


def serialisable(msg):
    """True if rospy can serialise ``msg`` (and so send it intact)."""
    try:
        msg.serialize(io.BytesIO())
        return True
    except Exception:       # struct.error, genpy.SerializationError, ...
        return False


def subscribed_topics(exclude):
    """{topic: type} of the topics other nodes subscribe to."""
    master = rosgraph.Master(rospy.get_name())
    _, subs, _ = master.getSystemState()
    types = dict(master.getTopicTypes())
    me = rospy.get_name()
    out = {}
    for topic, nodes in subs:
        if topic in exclude or not [n for n in nodes if n != me]:
            continue
        if topic in types and types[topic] != '*':
            out[topic] = types[topic]
    return out


# The protocol role that owns a topic, by its last name component.
ROLES = {'sync_time': 'cm', 'capture_data': 'cm', 'round_status': 'cm',
         'decision': 'dm', 'sync_ack': 'cpm', 'client_result': 'dpm',
         'clock_state': 'cpm', 'capture_command': 'cpm', 'dpm_state': 'dpm',
         'skeleton': 'sensor', 'image': 'sensor', 'imu': 'sensor',
         'joint_states': 'sensor', 'audio': 'sensor', 'samples': 'sensor',
         'input': 'sensor', 'captured': 'dpm', 'odom': 'base',
         'velocity': 'robot', 'led1': 'robot', 'led2': 'robot',
         'sound': 'robot'}


def owner(topic, senders):
    """A caller id the protocol lets publish on ``topic``, or None."""
    parts = topic.strip('/').split('/')
    if parts[-1] == 'action_start':         # a node's own ~action_start
        return '/' + parts[0]
    if parts == ['server', 'clock_state']:
        role, client = 'cm', None
    elif parts[-1] in ('sync_ack', 'client_result'):
        role, client = ROLES[parts[-1]], 'left'     # keyed by client_id
    else:
        role = ROLES.get(parts[-1])
        client = parts[0] if len(parts) > 1 else None
    return sorted(senders.names(role, client))[0] if role else None


def main():
    init_checker('fuzz_publisher')
    seed = rospy.get_param('~seed', 1)
    count = rospy.get_param('~count', 2000)
    rate = rospy.get_param('~rate', 400.0)
    settle = rospy.get_param('~settle', 2.0)
    impersonate = rospy.get_param('~impersonate', False)
    exclude = set(EXCLUDE) | set(rospy.get_param('~exclude', []))
    rng = random.Random(seed)
    fuzzer = Fuzzer(rng)

    def on_status(msg):
        fuzzer.round = max(fuzzer.round, msg.round)
    rospy.Subscriber('/round_status',
                     roslib.message.get_message_class('hri_sync/RoundStatus'),
                     on_status)
    topics = subscribed_topics(exclude)
    senders = Senders()
    pubs = {}
    for topic, kind in sorted(topics.items()):
        cls = roslib.message.get_message_class(kind)
        if cls is None:
            rospy.logwarn('fuzz: %s: unknown type %s, skipped', topic, kind)
            continue
        caller = owner(topic, senders) if impersonate else None
        pubs[topic] = (cls, rospy.Publisher(
            topic, cls, queue_size=1000,
            headers={'callerid': caller} if caller else None))
    rospy.loginfo('fuzz: seed %d, %d messages on each of %d topics: %s',
                  seed, count, len(pubs), ', '.join(
                      '%s (%s)' % (t, topics[t]) for t in sorted(pubs)))
    time.sleep(settle)          # let the subscribers connect
    sent = {t: 0 for t in pubs}
    redrawn = 0
    period = 1.0 / rate
    tick = time.monotonic()
    for _ in range(count):
        for topic in sorted(pubs):
            if rospy.is_shutdown():
                break
            cls, pub = pubs[topic]
            msg = fuzzer.message(cls)
            while not serialisable(msg):
                redrawn += 1
                msg = fuzzer.message(cls)
            pub.publish(msg)
            sent[topic] += 1
            tick += period
            time.sleep(max(0.0, tick - time.monotonic()))
    time.sleep(settle)          # let the queues drain
    print(json.dumps({'seed': seed, 'sent': sent, 'redrawn': redrawn,
                      'impersonate': bool(impersonate)}))
    sys.stdout.flush()


if __name__ == '__main__':
    main()
