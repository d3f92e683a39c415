"""A recorded session sorted into rounds (no ROS).

``build_session`` takes what a bag holds (``hri_sync.tools.bag``'s
``BagContents``, or anything with its ``topics``/``of_type`` interface)
and files every message under its round and client: the protocol
(SyncTime, SyncAck, CaptureData, RoundStatus, CaptureCommand,
ClientResult, Decision), each client's clock states, the captured frames,
and what DJ Rob and the music did.  The calibration window (its order,
results and answer on the ``calibration/`` topics) is the session's
``calibration``, not a round.  Messages are duck-typed (rosbags
dataclasses or stand-ins with the same fields).
"""
import math
from dataclasses import dataclass, field

import yaml

from hri_sync.wire.vocabulary import CALIBRATION_NS, RoundState

ROUND_ABORTED = RoundState.ABORTED


def secs(t):
    """A rosbags Time (sec, nanosec) or rospy-like time in seconds."""
    if t is None:
        return math.nan
    if hasattr(t, 'to_sec'):
        return t.to_sec()
    return t.sec + t.nanosec * 1e-9


# Where a recording made before std_msgs/Header (bag.PRE_HEADER) has
# the global stamp: SyncTime, SyncAck, RoundStatus, Decision and Beat in
# ``stamp``, CaptureData in ``cr_t`` (CR_T), ActionStart in ``actual``;
# CaptureCommand and ClientResult had none.
PRE_HEADER_STAMPS = ('stamp', 'cr_t', 'actual')


def stamp_of(msg):
    """A message's stamp in s: its ``header.stamp``, or, recorded before
    the header, its stamp field (``PRE_HEADER_STAMPS``); NaN if none."""
    header = getattr(msg, 'header', None)
    if header is not None:
        return secs(header.stamp)
    for name in PRE_HEADER_STAMPS:
        if hasattr(msg, name):
            return secs(getattr(msg, name))
    return math.nan


def field_or_nan(msg, name):
    """``msg.name`` as a float, NaN when the recorded message lacks it
    (recorded before that field existed)."""
    value = getattr(msg, name, None) if msg is not None else None
    try:
        return float(value)
    except (TypeError, ValueError):
        return math.nan


def is_calibration(topic):
    """True for a topic of the calibration window:
    ``[NS]/calibration/<protocol topic>``."""
    parts = [p for p in topic.split('/') if p]
    return len(parts) >= 2 and parts[-2] == CALIBRATION_NS


def client_of(topic, suffix):
    """The client id in ``/<client_id>/suffix`` (the last namespace)."""
    head = topic[:-len(suffix)] if topic.endswith(suffix) else topic
    parts = [p for p in head.split('/') if p]
    return parts[-1] if parts else ''


@dataclass
class Round:
    """What one round put on the wire, by bag time ``t`` (s)."""

    n: int
    sync: object = None             # Recorded SyncTime
    acks: dict = field(default_factory=dict)       # client -> Recorded
    capture: object = None          # Recorded CaptureData
    statuses: list = field(default_factory=list)   # [Recorded RoundStatus]
    commands: dict = field(default_factory=dict)   # client -> Recorded
    results: dict = field(default_factory=dict)    # client -> Recorded
    decision: object = None         # Recorded Decision
    starts: dict = field(default_factory=dict)     # (client, action) -> msg
    beats: list = field(default_factory=list)      # [Recorded Beat]
    duplicates: list = field(default_factory=list)  # texts

    @property
    def start(self):
        """Global start of the window (CR_T + STR_AFT), NaN if none."""
        if self.capture is None:
            return math.nan
        c = self.capture.msg
        return stamp_of(c) + c.str_aft

    @property
    def window_start(self):
        """Global start of the window from its CaptureData or, without
        one, the results' capture_start (NaN if neither)."""
        if self.capture is not None:
            return self.start
        starts = [secs(r.msg.capture_start) for r in self.results.values()]
        return min(starts) if starts else math.nan

    @property
    def end(self):
        if self.capture is None:
            return math.nan
        return self.start + self.capture.msg.dur

    @property
    def aborted_reason(self):
        """The CM's abort reason, or None."""
        for s in self.statuses:
            if s.msg.state == ROUND_ABORTED:
                return s.msg.reason
        return None

    @property
    def participants(self):
        """The clients whose results decide the round."""
        if self.decision is not None:
            return list(self.decision.msg.clients)
        return sorted(self.results)

    @property
    def first_t(self):
        """Bag time of the round's first message."""
        ts = [r.t for r in ([self.sync, self.capture, self.decision]
                            + list(self.acks.values())
                            + list(self.results.values())
                            + self.statuses) if r is not None]
        return min(ts) if ts else math.nan


@dataclass
class Session:
    """A recording sorted into rounds and clients."""

    path: str
    topics: dict                    # topic -> type
    rounds: dict = field(default_factory=dict)      # n -> Round
    calibration: object = None      # Round 0 of the calibration/ topics
    config: dict = field(default_factory=dict)
    config_error: str = ''
    clock_states: dict = field(default_factory=dict)  # client -> [Recorded]
    captured: dict = field(default_factory=dict)    # client -> [(stamp, msg)]
    raw: dict = field(default_factory=dict)         # client -> [(stamp, msg)]
    odom: list = field(default_factory=list)        # [Recorded Odometry]
    cmd_vel: list = field(default_factory=list)     # [Recorded Twist]
    leds: list = field(default_factory=list)        # [Recorded Led]
    sounds: list = field(default_factory=list)      # [Recorded Sound]
    old_types: dict = field(default_factory=dict)
    pre_header: list = field(default_factory=list)  # see bag.PRE_HEADER
    start: float = 0.0              # bag time of the first message
    end: float = 0.0

    def round(self, n):
        return self.rounds.setdefault(n, Round(n))

    def has(self, msgtype, suffix=''):
        """True if a topic of ``msgtype`` ending in ``suffix`` was
        recorded."""
        return any(kind == msgtype and topic.endswith(suffix)
                   for topic, kind in self.topics.items())

    @property
    def cut_off(self):
        """Rounds that began but have no decision in the recording."""
        return sorted(n for n, r in self.rounds.items()
                      if r.decision is None)

    def began_before(self, rnd, clock):
        """Whether decided round ``rnd``'s window began before the
        recording (a later part of a split one, or its decision repeated
        as latched): its frames are not all here. ``clock``: the
        recorder's BagClock."""
        return rnd.decision is not None and \
            rnd.window_start < clock.to_global(self.rounds_start)

    @property
    def rounds_start(self):
        """Bag time of the first round message (the recording's start
        without one): where the recording of the rounds begins, whatever
        else (a config, odometry) came before it."""
        ts = [r.first_t for r in self.rounds.values()
              if math.isfinite(r.first_t)]
        return min(ts, default=self.start)

    @property
    def cut_at_start(self):
        """Decided rounds whose window began before the recording."""
        clock = server_clock(self)
        return sorted(n for n, r in self.rounds.items()
                      if self.began_before(r, clock))

    def next_round_t(self, n):
        """Bag time the round after ``n`` began (inf: none)."""
        later = [r.first_t for m, r in self.rounds.items() if m > n]
        later = [t for t in later if math.isfinite(t)]
        return min(later) if later else math.inf


def _keyed(target, key, rec, what, rnd):
    if key in target:
        rnd.duplicates.append('second %s from %s (kept the first)'
                              % (what, key))
        return
    target[key] = rec


def _first(rnd, attr, rec, what):
    """Keep ``rec`` as the round's ``attr`` unless one came before."""
    if getattr(rnd, attr) is None:
        setattr(rnd, attr, rec)
    else:
        rnd.duplicates.append('second %s (kept the first)' % what)


def build_session(contents):
    """Sort ``contents`` (a BagContents) into a Session."""
    s = Session(contents.path, dict(contents.topics),
                old_types=dict(getattr(contents, 'old_types', {})),
                pre_header=sorted(getattr(contents, 'pre_header', [])),
                start=contents.start, end=contents.end)

    def each(kind, suffix=''):
        return [r for r in contents.of_type('hri_sync/' + kind, suffix)
                if not is_calibration(r.topic)]

    _calibration(s, contents)
    for r in each('SyncTime'):
        _first(s.round(r.msg.round), 'sync', r, 'SyncTime')
    for r in each('SyncAck'):
        rnd = s.round(r.msg.round)
        _keyed(rnd.acks, r.msg.client_id, r, 'SyncAck', rnd)
    for r in each('CaptureData'):
        _first(s.round(r.msg.round), 'capture', r, 'CaptureData')
    for r in each('RoundStatus'):
        s.round(r.msg.round).statuses.append(r)
    for r in each('CaptureCommand'):
        rnd = s.round(r.msg.round)
        _keyed(rnd.commands, client_of(r.topic, '/capture_command'), r,
               'CaptureCommand', rnd)
    for r in each('ClientResult'):
        rnd = s.round(r.msg.round)
        _keyed(rnd.results, r.msg.client_id, r, 'ClientResult', rnd)
    for r in each('Decision'):
        _first(s.round(r.msg.round), 'decision', r, 'Decision')
    for r in each('ActionStart'):
        if r.msg.round:
            s.round(r.msg.round).starts.setdefault(
                (r.msg.client_id, r.msg.action), r.msg)
    for r in each('Beat'):
        if r.msg.round in s.rounds:
            s.rounds[r.msg.round].beats.append(r)
    for r in each('ClockState'):
        who = r.msg.client_id or client_of(r.topic, '/clock_state')
        s.clock_states.setdefault(who, []).append(r)
    for kind in ('Skeleton', 'Sample'):
        for suffix, target in (('/captured', s.captured),
                               ('/skeleton', s.raw), ('/samples', s.raw)):
            for r in each(kind, suffix):
                target.setdefault(client_of(r.topic, suffix), []).append(
                    (stamp_of(r.msg), r.msg))
    for frames in list(s.captured.values()) + list(s.raw.values()):
        frames.sort(key=lambda f: f[0])
    s.odom = contents.of_type('nav_msgs/Odometry')
    s.cmd_vel = contents.of_type('geometry_msgs/Twist', 'commands/velocity')
    s.leds = [r for r in contents.of_type('hri_sync/Led')
              if '/commands/' in r.topic]
    s.sounds = [r for r in contents.of_type('hri_sync/Sound')
                if '/commands/' in r.topic]
    for r in contents.of_type('std_msgs/String', '/dance_off/config')[:1]:
        try:
            config = yaml.safe_load(r.msg.data)
        except yaml.YAMLError as e:
            s.config_error = '/dance_off/config is not YAML: %s' % e
            continue
        if isinstance(config, dict):
            s.config = config
        else:
            s.config_error = ('/dance_off/config is not a mapping: %r'
                              % (config,))
    return s


def _calibration(s, contents):
    """The calibration window's order, results and answer into
    ``s.calibration`` (None when the recording has none)."""
    def each(kind):
        return [r for r in contents.of_type('hri_sync/' + kind)
                if is_calibration(r.topic)]
    cal = Round(0)
    for r in each('CaptureData'):
        _first(cal, 'capture', r, 'calibration CaptureData')
    for r in each('ClientResult'):
        _keyed(cal.results, r.msg.client_id, r, 'calibration ClientResult',
               cal)
    for r in each('Decision'):
        _first(cal, 'decision', r, 'calibration Decision')
    if cal.capture or cal.results or cal.decision:
        s.calibration = cal


class BagClock:
    """Bag (receipt) time to global time, by the clock model of the host
    that recorded: the server's ``ClockState`` (dance_off.launch records on
    the server's host). Without one, bag time is taken as global time."""

    def __init__(self, states=()):
        self.states = sorted(((r.t, r.msg) for r in states
                              if r.msg.ok and math.isfinite(r.msg.offset)),
                             key=lambda s: s[0])

    @property
    def known(self):
        return bool(self.states)

    def _state(self, t):
        chosen = self.states[0][1]
        for when, msg in self.states:
            if when > t:
                break
            chosen = msg
        return chosen

    def to_global(self, t):
        if not self.states:
            return t
        m = self._state(t)
        return t + m.offset + m.drift * (t - m.local_ref)

    def to_bag(self, g):
        """Inverse of to_global (one fixed-point step is exact enough for
        drifts below 1e-3)."""
        if not self.states:
            return g
        t = g
        for _ in range(3):
            t = g - (self.to_global(t) - t)
        return t


def server_clock(session, server='server'):
    """The BagClock of ``session``'s recorder (the server's host)."""
    return BagClock(session.clock_states.get(server, []))
