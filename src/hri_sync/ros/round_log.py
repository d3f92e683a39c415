"""RoundLog: what each round put on the wire, for monitors and tests."""
import threading

import roslib.message
import rospy

from hri_sync.msg import CaptureData, ClientResult, Decision, SyncAck
from hri_sync.ros.names import client_topic, protocol_topic
from hri_sync.tools.round_summary import frames_brought
from hri_sync.wire.protocol import Capture


def truth_of(msg):
    """(true time, sample id) of a captured sample whose sensor ran on the
    true clock: Sample carries it in ``value`` (signal true_time), Skeleton
    in ``device_stamp``."""
    if hasattr(msg, 'device_stamp'):
        t = msg.device_stamp.to_sec()
        return t, t
    return msg.value, msg.index


class RoundLog:
    """Records what a round put on the wire, for reports and tests.

    ``rounds[n]`` holds 'acks' {client: SyncAck}, 'capture' (CaptureData),
    'results' {client: ClientResult}, 'captured' {client: [(global stamp,
    true time, id)]}, 'decision' (Decision).  With an ``inbox``
    (``hri_sync.ros.inbox.Inbox``), only valid messages from their
    rightful senders are recorded (a result from any node: a late window's
    comes from the CPM).
    """

    def __init__(self, clients, captured_type=None, inbox=None):
        self.rounds = {}
        self.captured_clients = list(clients) if captured_type else []
        self.lock = threading.Lock()
        topics = (('sync_ack', SyncAck, 'acks', 'cpm'),
                  ('capture_data', CaptureData, 'capture', 'cm'),
                  ('client_result', ClientResult, 'results', None),
                  ('decision', Decision, 'decision', 'dm'))
        for name, cls, key, role in topics:
            topic = protocol_topic(name)
            if inbox is None:
                rospy.Subscriber(topic, cls, self._put, (key,))
            else:
                inbox.subscribe(
                    topic, cls, lambda m, k=key: self._put(m, (k,)), role,
                    client=(lambda m: m.client_id) if key == 'acks'
                    else None)
        if captured_type:
            cls = roslib.message.get_message_class(captured_type)
            for c in clients:
                rospy.Subscriber(client_topic(c, 'captured'), cls,
                                 self._captured, c, queue_size=100000)
        self._pending = {}

    def round(self, n):
        """The record of round ``n`` (created empty if needed)."""
        return self.rounds.setdefault(n, {'acks': {}, 'capture': None,
                                          'results': {}, 'captured': {},
                                          'decision': None})

    def _put(self, msg, args):
        key = args[0]
        with self.lock:
            r = self.round(msg.round)
            if key in ('acks', 'results'):
                r[key][msg.client_id] = msg
            else:
                r[key] = msg

    def _captured(self, msg, client):
        truth, ident = truth_of(msg)
        with self.lock:
            self._pending.setdefault(client, []).append(
                (msg.header.stamp.to_sec(), truth, ident))

    def forget(self, n):
        """Drop the record of round ``n`` (a monitor that has reported it:
        over a study day of hours the captured samples of every round
        would otherwise stay, and each new sample be matched against every
        old window).  A late message for it starts an empty record."""
        with self.lock:
            self.rounds.pop(n, None)

    def assign_captured(self):
        """File captured samples under the round whose window holds them."""
        with self.lock:
            windows = [(c.start, c.end, r) for c, r in (
                (Capture.from_msg(r['capture']), r)
                for r in self.rounds.values() if r['capture'])]
            for client, samples in self._pending.items():
                for s in samples:
                    for start, end, r in windows:
                        if start <= s[0] < end:
                            r['captured'].setdefault(client, []).append(s)
            self._pending = {}

    def missing_captured(self, n):
        """Clients of round ``n`` whose result used more frames than
        their captured topic has brought so far (a DPM republishes a
        window's last samples after its result)."""
        self.assign_captured()
        with self.lock:
            r = self.round(n)
            return [c for c in self.captured_clients if c in r['results']
                    and frames_brought(r['captured'].get(c, [])) <
                    r['results'][c].frames]
