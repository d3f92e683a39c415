"""The thin ROS glue the nodes share: params, time conversion, the CPM.

This is the only module of the package that imports rospy.
"""
import math
import subprocess
from collections import Counter
import threading
import time

import roslib.message
import rospy

from hri_sync import ntp
from hri_sync.clock import GlobalClock
from hri_sync.msg import (CaptureData, ClientResult, ClockState, Decision,
                          SyncAck, SyncTime)
from hri_sync.protocol import Capture, ClientSchedule, Late


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


def run_node(name, main):
    """init_node, then run ``main()``; a ParamError ends the node with a
    fatal message naming the param (exit status 2)."""
    rospy.init_node(name)
    try:
        main()
    except ParamError as e:
        rospy.logfatal('%s: %s', rospy.get_name(), e)
        raise SystemExit(2)
    except rospy.ROSInterruptException:
        pass


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
    sleep-based threading.Timer, which would hang under libfaketime)."""
    def run():
        if delay > 0:
            time.sleep(delay)
        if not rospy.is_shutdown():
            callback(*args)
    threading.Thread(target=run, daemon=True).start()


def stamp(t):
    """A float of seconds as rospy.Time (NaN becomes 0)."""
    return rospy.Time.from_sec(t) if math.isfinite(t) else rospy.Time()


def secs(t):
    """A rospy.Time or Duration as float seconds."""
    return t.to_sec()


class SyncedClock:
    """A host's global clock, kept against the time server.

    Reads ``~ntp_server``, ``~ntp_port``, ``~ntp_exchanges``,
    ``~ntp_timeout``, ``~resync_period`` and ``~sync_method``; re-measures
    every resync period in a thread and publishes the model latched on
    ``/<name>/clock_state`` (hri_sync/ClockState).
    """

    def __init__(self, name):
        self.name = name
        self.server = param('ntp_server', '127.0.0.1', str)
        self.port = param('ntp_port', 11123, int,
                          lambda p: 0 < p < 65536, 'a UDP port')
        self.exchanges = param('ntp_exchanges', 8, int, lambda n: n >= 1,
                               'at least one exchange')
        self.timeout = param('ntp_timeout', 0.5, float, positive, '> 0 s')
        self.resync_period = param('resync_period', 5.0, float, positive,
                                   '> 0 s')
        self.sync_method = param(
            'sync_method', 'software', str,
            lambda m: m in ('software', 'step'), "'software' or 'step'")
        self.clock = GlobalClock()
        self.last_error = 'not measured yet'
        self._lock = threading.Lock()
        self._state_pub = rospy.Publisher('/%s/clock_state' % name,
                                          ClockState, queue_size=1,
                                          latch=True)
        threading.Thread(target=self._resync_loop, daemon=True).start()

    def measure(self):
        """One NTP burst into the clock model; returns an error or None."""
        with self._lock:
            try:
                if self.sync_method == 'step':
                    subprocess.run(['chronyc', 'makestep'], check=True,
                                   timeout=5, capture_output=True)
                m = ntp.measure(self.server, self.port, self.exchanges,
                                self.timeout)
            except (ntp.NtpError, OSError, subprocess.SubprocessError) as e:
                self.last_error = str(e)
                self._publish_state(False, self.last_error)
                return self.last_error
            self.clock.add(m)
            self.last_error = ''
            self._publish_state(True, '')
            return None

    def wait_synced(self, timeout):
        """Block until the first measurement succeeded; False on timeout."""
        return wait_for(lambda: self.clock.synced, timeout, 0.05)

    def _publish_state(self, ok, reason):
        s = self.clock.state()
        self._state_pub.publish(ClockState(
            client_id=self.name, ok=ok and self.clock.synced,
            reason=reason, local_ref=s['local_ref'], offset=s['offset'],
            drift=s['drift'], uncertainty=min(s['uncertainty'], 1e9),
            samples=s['samples']))

    def _resync_loop(self):
        # Re-measure after 0.5, 1, 2, 4 s at start, so the drift is known
        # within seconds instead of one resync period.
        pause = 0.5
        while not rospy.is_shutdown():
            error = self.measure()
            if error:
                rospy.logwarn_throttle(10, '%s: clock sync failed: %s'
                                       % (self.name, error))
            time.sleep(min(pause, self.resync_period))
            pause *= 2


class ClientProcess:
    """The client process module: a global clock, ACKs and the schedule.

    Keeps a ``SyncedClock``, ACKs ``/sync_time`` after a fresh measurement
    (or NACKs with the reason, also when the uncertainty exceeds
    ``~max_uncertainty``) and turns ``/capture_data`` into
    ``on_capture(Scheduled)`` or ``on_late(Late)``.
    """

    def __init__(self, client_id, on_capture, on_late=None):
        self.client_id = client_id
        self.on_capture = on_capture
        self.on_late = on_late
        self.max_uncertainty = param('max_uncertainty', 0.005, float,
                                     positive, '> 0 s')
        self.synced = SyncedClock(client_id)
        self.clock = self.synced.clock
        self.schedule = ClientSchedule(client_id)
        self._ack_pub = rospy.Publisher('/sync_ack', SyncAck, queue_size=10)
        rospy.Subscriber('/sync_time', SyncTime, self._on_sync_time,
                         queue_size=10)
        rospy.Subscriber('/capture_data', CaptureData, self._on_capture_data,
                         queue_size=10)

    def _on_sync_time(self, msg):
        local_rx = time.time()
        error = self.synced.measure()
        ok, reason = error is None, error or ''
        if ok and self.clock.uncertainty > self.max_uncertainty:
            ok = False
            reason = ('offset uncertainty %.2f ms exceeds ~max_uncertainty '
                      '%.2f ms' % (self.clock.uncertainty * 1e3,
                                   self.max_uncertainty * 1e3))
        self.schedule.on_sync(msg.round, ok)
        now = time.time()
        synced = self.clock.synced
        self._ack_pub.publish(SyncAck(
            round=msg.round, client_id=self.client_id, ok=ok, reason=reason,
            offset=self.clock.offset_at(now) if synced else math.nan,
            uncertainty=self.clock.uncertainty if synced else math.nan,
            drift=self.clock.drift,
            sync_received=stamp(self.clock.to_global(local_rx)
                                if synced else math.nan),
            stamp=stamp(self.clock.to_global(now) if synced else math.nan)))
        if not ok:
            rospy.logerr('%s: NACK round %d: %s', self.client_id, msg.round,
                         reason)

    def _on_capture_data(self, msg):
        capture = Capture(msg.round, secs(msg.cr_t), msg.str_aft, msg.dur,
                          list(msg.clients))
        before = Counter(self.schedule.ignored)
        order = self.schedule.on_capture(capture, self.clock.now(), self.clock)
        if order is None:
            why = ', '.join(self.schedule.ignored - before)
            log = (rospy.loginfo if why == 'not_a_participant'
                   else rospy.logwarn)
            log('%s: capture_data of round %d ignored (%s); ignored so far: '
                '%s', self.client_id, msg.round, why,
                dict(self.schedule.ignored))
            return
        if isinstance(order, Late):
            rospy.logerr('%s: %s', self.client_id, order.reason)
            if self.on_late:
                self.on_late(order)
            return
        self.on_capture(order)


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
    true time, id)]}, 'decision' (Decision).
    """

    def __init__(self, clients, captured_type=None):
        self.rounds = {}
        self.lock = threading.Lock()
        rospy.Subscriber('/sync_ack', SyncAck, self._put, ('acks',))
        rospy.Subscriber('/capture_data', CaptureData, self._put,
                         ('capture',))
        rospy.Subscriber('/client_result', ClientResult, self._put,
                         ('results',))
        rospy.Subscriber('/decision', Decision, self._put, ('decision',))
        if captured_type:
            cls = roslib.message.get_message_class(captured_type)
            for c in clients:
                rospy.Subscriber('/%s/captured' % c, cls, self._captured,
                                 c, queue_size=100000)
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

    def assign_captured(self):
        """File captured samples under the round whose window holds them."""
        with self.lock:
            for client, samples in self._pending.items():
                for s in samples:
                    for n, r in self.rounds.items():
                        c = r['capture']
                        start = c and c.cr_t.to_sec() + c.str_aft
                        if c and start <= s[0] < start + c.dur:
                            r['captured'].setdefault(client, []).append(s)
            self._pending = {}
