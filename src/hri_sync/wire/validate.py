"""Input validation at the boundary: one check per incoming message type.

No ROS.  Each message type has a function taking the message's fields as
keyword arguments of plain values (times as float seconds, nested
messages as dicts or tuples, arrays as sequences) and a ``Context``: the
receiver's global now, the round in progress and the ``Limits``.  It
returns None for an acceptable message and raises ``Rejected`` otherwise,
with a short machine-readable ``reason`` key, the ``field`` at fault and a
human message.  ``check(msg_type, fields, ctx)`` dispatches by the ROS
type name (``'hri_sync/SyncAck'``).

What is checked: times finite, positive and representable by a ROS time
(below 2**32 s: rospy cannot serialise a later stamp, and a publisher that
tried corrupts its link for good), within ``[now - past, now + future]``
of the receiver's global now where the message says when it was sent;
durations and STR_AFT within limits; round numbers within
``[round - rounds_behind, round + rounds_ahead]`` of the round in
progress; names, lists and strings of bounded size; a sample's array
lengths, its stamps and values.  Where a message's contract allows "no
value" it is accepted: NaN for a score, offset or joint that does not
exist, a zero time where the contract says 0 means unknown.  Checks that
need history (a repeated sample stamp) are in ``StampOrder``.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from typing import Any, Callable, Collection, Optional

from hri_sync.wire.times import TIME_LIMIT, fits_ros_time
from hri_sync.wire.vocabulary import (CALIBRATION_ROUND, NUM_JOINTS, Action,
                                      ActionEnd, NoiseSource, Outcome,
                                      ResultStatus, RoundState)

NAME_RE = re.compile(r'^[A-Za-z][A-Za-z0-9_]*$')


class Rejected(ValueError):
    """A message that must not be acted on.

    ``reason`` is a short key for counting (``'time_not_finite'``),
    ``field`` the field at fault, ``str(e)`` a message for a human.
    """

    def __init__(self, reason: str, message: str,
                 field: str | None = None) -> None:
        super().__init__(message)
        self.reason = reason
        self.field = field


@dataclass(frozen=True)
class Limits:
    """What a receiver accepts; every bound is configurable."""

    past: float = 600.0          # s a sent stamp may lie before now
    future: float = 60.0         # s it may lie after now (clock error)
    max_dur: float = 3600.0      # s, capture duration
    min_str_aft: float = 0.0     # s
    max_str_aft: float = 60.0    # s
    rounds_behind: int = 1       # rounds before the one in progress
    rounds_ahead: int = 1        # rounds after the one in progress
    max_offset: float = 86400.0  # s, |global - local| of a client
    max_uncertainty: float = 1.0  # s, of an ok clock
    max_drift: float = 0.01      # dimensionless
    max_latency: float = 10.0    # s, sync_time sent to received
    max_clients: int = 64
    max_name: int = 64           # characters of a client id
    max_text: int = 4096         # characters of a reason or frame id
    max_diagnostics: int = 64    # key/value pairs of a result
    max_frames: int = 10 ** 7    # samples of one window
    max_coordinate: float = 100.0  # m, a joint's distance to the sensor
    max_speed: float = 100.0     # m/s or rad/s of a velocity
    nan_joints: bool = True      # NaN positions: a joint not tracked


@dataclass(frozen=True)
class Context:
    """The receiver's state a message is judged against.

    ``now``: the receiver's global now (None: unknown, no window check);
    ``local_now``: its local now (for a ClockState of its own host);
    ``round``: the round in progress (None: any round >= 1); ``client``:
    the client id a message must name (None: any); ``sync_sent``: the
    stamp of the round's SyncTime, for an ACK's dispatch latency (None:
    unknown); ``calibration``: a message of the calibration window (the
    calibration/ topics), whose round is ``CALIBRATION_ROUND``.
    """

    now: Optional[float] = None
    local_now: Optional[float] = None
    round: Optional[int] = None
    client: Optional[str] = None
    sync_sent: Optional[float] = None
    calibration: bool = False
    limits: Limits = field(default_factory=Limits)


# --- values --------------------------------------------------------------

def number(x: float, what: str, lo: float = -math.inf, hi: float = math.inf,
           nan: bool = False) -> float:
    """A finite number within [lo, hi] (NaN too with ``nan``)."""
    if isinstance(x, bool) or not isinstance(x, (int, float)):
        raise Rejected('not_a_number', '%s=%r is not a number' % (what, x),
                       what)
    if math.isnan(x):
        if nan:
            return x
        raise Rejected('not_finite', '%s is NaN' % what, what)
    if math.isinf(x):
        raise Rejected('not_finite', '%s=%r is not finite' % (what, x), what)
    if not lo <= x <= hi:
        raise Rejected('out_of_range', '%s=%r is outside [%g, %g]'
                       % (what, x, lo, hi), what)
    return x


def time_value(t: float | str, what: str, optional: bool = False) -> float:
    """A time in s: finite, positive, below 2**32 (0 with ``optional``)."""
    if isinstance(t, bool) or not isinstance(t, (int, float)):
        raise Rejected('not_a_number', '%s=%r is not a time' % (what, t),
                       what)
    if optional and t == 0:
        return t
    if not math.isfinite(t):
        raise Rejected('time_not_finite', '%s=%r is not a finite time'
                       % (what, t), what)
    if t <= 0:
        raise Rejected('time_not_positive', '%s=%r is not a positive time'
                       % (what, t), what)
    if not fits_ros_time(t):
        raise Rejected('time_unrepresentable', '%s=%r s is beyond the last '
                       'ROS time (%d s)' % (what, t, TIME_LIMIT), what)
    return t


def time_near(t: float, what: str, ctx: Context, ahead: float = 0.0,
              behind: float = 0.0, optional: bool = False) -> float:
    """A valid time within [now - past - behind, now + future + ahead]
    of ``ctx.now`` (unchecked when now is unknown)."""
    time_value(t, what, optional)
    if ctx.now is None or (optional and t == 0):
        return t
    lim = ctx.limits
    if t < ctx.now - lim.past - behind:
        raise Rejected('time_too_old', '%s=%.6f is %.1f s before now (limit'
                       ' %g s)' % (what, t, ctx.now - t, lim.past + behind),
                       what)
    if t > ctx.now + lim.future + ahead:
        raise Rejected('time_in_future', '%s=%.6f is %.1f s after now (limit'
                       ' %g s)' % (what, t, t - ctx.now, lim.future + ahead),
                       what)
    return t


def duration(d: float, what: str, ctx: Context) -> float:
    """A duration within (0, max_dur]."""
    number(d, what, 0.0, ctx.limits.max_dur)
    if d <= 0:
        raise Rejected('out_of_range', '%s=%r is not > 0' % (what, d), what)
    return d


def round_number(r: int, ctx: Context, what: str = 'round') -> int:
    """A round number >= 1, near the round in progress; on a calibration
    topic, ``CALIBRATION_ROUND``."""
    if isinstance(r, bool) or not isinstance(r, int):
        raise Rejected('not_a_number', '%s=%r is not a round number'
                       % (what, r), what)
    if ctx.calibration:
        if r != CALIBRATION_ROUND:
            raise Rejected('round_invalid', '%s=%d: the calibration window '
                           'is round %d' % (what, r, CALIBRATION_ROUND),
                           what)
        return r
    if r < 1:
        raise Rejected('round_invalid', '%s=%d: rounds count from 1'
                       % (what, r), what)
    if ctx.round is None:
        return r
    lim = ctx.limits
    if r < ctx.round - lim.rounds_behind:
        raise Rejected('round_old', '%s %d is more than %d before round %d'
                       % (what, r, lim.rounds_behind, ctx.round), what)
    if r > ctx.round + lim.rounds_ahead:
        raise Rejected('round_future', '%s %d is more than %d after round %d'
                       % (what, r, lim.rounds_ahead, ctx.round), what)
    return r


def name(s: str, what: str, ctx: Context) -> str:
    """A client id: a letter, then letters, digits or '_'."""
    if not isinstance(s, str):
        raise Rejected('not_a_string', '%s=%r is not a string' % (what, s),
                       what)
    if not s:
        raise Rejected('name_empty', '%s is empty' % what, what)
    if len(s) > ctx.limits.max_name:
        raise Rejected('name_too_long', '%s is %d characters (limit %d)'
                       % (what, len(s), ctx.limits.max_name), what)
    if not NAME_RE.match(s):
        raise Rejected('name_invalid', '%s=%r is not a client id'
                       % (what, s[:40]), what)
    return s


def client_name(s: str, what: str, ctx: Context) -> str:
    """A client id that is ``ctx.client`` when that is set."""
    name(s, what, ctx)
    if ctx.client is not None and s != ctx.client:
        raise Rejected('wrong_client', '%s=%r, expected %r'
                       % (what, s, ctx.client), what)
    return s


def names(items: list[Any], what: str, ctx: Context,
          empty: bool = True, graph: bool = False) -> list[Any]:
    """A list of distinct client ids (``graph``: or graph names, client
    ids joined by '/'), at most ``max_clients``."""
    items = list(items)
    if not items and not empty:
        raise Rejected('list_empty', '%s is empty' % what, what)
    if len(items) > ctx.limits.max_clients:
        raise Rejected('list_too_long', '%s has %d entries (limit %d)'
                       % (what, len(items), ctx.limits.max_clients), what)
    for s in items:
        for part in s.split('/') if graph and isinstance(s, str) else [s]:
            name(part, what, ctx)
    if len(set(items)) != len(items):
        raise Rejected('list_duplicate', '%s lists a client twice' % what,
                       what)
    return items


def text(s: str, what: str, ctx: Context) -> str:
    """A free text (a reason) of at most ``max_text`` characters."""
    if not isinstance(s, str):
        raise Rejected('not_a_string', '%s=%r is not a string'
                       % (what, s), what)
    if len(s) > ctx.limits.max_text:
        raise Rejected('text_too_long', '%s is %d characters (limit %d)'
                       % (what, len(s), ctx.limits.max_text), what)
    return s


def choice(s: Any, what: str, allowed: Collection[Any]) -> Any:
    """One of ``allowed``."""
    if s not in allowed:
        raise Rejected('unknown_value', '%s=%r is not one of %s'
                       % (what, str(s)[:40], ', '.join(map(str, allowed))),
                       what)
    return s


def count(n: int, what: str, hi: int) -> int:
    """A whole number within [0, hi]."""
    if isinstance(n, bool) or not isinstance(n, int):
        raise Rejected('not_a_number', '%s=%r is not a count' % (what, n),
                       what)
    if not 0 <= n <= hi:
        raise Rejected('out_of_range', '%s=%d is outside [0, %d]'
                       % (what, n, hi), what)
    return n


def components(v: Any, keys: tuple[str, ...], what: str) -> list[Any]:
    """The components of a nested message (a dict or a sequence)."""
    if isinstance(v, dict):
        try:
            return [v[k] for k in keys]
        except KeyError as e:
            raise Rejected('malformed', '%s has no %s' % (what, e), what)
    try:
        out = list(v)
    except TypeError:
        raise Rejected('malformed', '%s=%r is not a %s' % (
            what, v, '/'.join(keys)), what)
    if len(out) != len(keys):
        raise Rejected('malformed', '%s has %d components, not %d'
                       % (what, len(out), len(keys)), what)
    return out


def array(items: list[Any], what: str, length: int) -> list[Any]:
    """A sequence of exactly ``length`` items."""
    try:
        items = list(items)
    except TypeError:
        raise Rejected('malformed', '%s is not an array' % what, what)
    if len(items) != length:
        raise Rejected('wrong_length', '%s has %d entries, not %d'
                       % (what, len(items), length), what)
    return items


def vector(v: Any, what: str, hi: float,
           keys: tuple[str, ...] = ('x', 'y', 'z'),
           nan: bool = False) -> list[float]:
    """A vector of numbers within [-hi, hi] (NaN too with ``nan``)."""
    return [number(c, '%s.%s' % (what, k), -hi, hi, nan)
            for k, c in zip(keys, components(v, keys, what))]


def header_stamp(header: Any, what: str = 'header') -> Any:
    """The stamp of a std_msgs/Header (a dict or an object)."""
    if isinstance(header, dict):
        if 'stamp' not in header:
            raise Rejected('malformed', '%s has no stamp' % what, what)
        return header['stamp']
    return getattr(header, 'stamp', None)


def header_time(header: Any, ctx: Context,
                optional: bool = False, ahead: float = 0.0,
                behind: float = 0.0) -> float:
    """The global ``header.stamp`` of a protocol message, checked by
    ``time_near`` (0 allowed with ``optional``), and its frame_id a
    bounded text; returns the stamp."""
    t = header_stamp(header)
    time_near(t, 'header.stamp', ctx, ahead=ahead, behind=behind,
              optional=optional)
    frame = (header.get('frame_id', '') if isinstance(header, dict)
             else getattr(header, 'frame_id', ''))
    text(frame, 'header.frame_id', ctx)
    return t


# --- messages of the timing model -----------------------------------------

def sync_time(*, header: Any, round: Any, ctx: Context) -> None:
    """/sync_time: the CM opens a round (header.stamp: when sent)."""
    header_time(header, ctx)
    round_number(round, ctx)


def sync_ack(*, header: Any, round: Any, client_id: Any, ok: Any, reason: Any,
             offset: Any, uncertainty: Any, drift: Any, sync_received: Any,
             ctx: Context, sent: Any = None) -> None:
    """/sync_ack: a client's ACK or NACK (header.stamp: when sent).

    ``sent`` (else ``ctx.sync_sent``): the stamp of the round's SyncTime,
    when known: then the dispatch latency (``sync_received - sent``) must
    lie within [-max_uncertainty, max_latency].
    """
    lim = ctx.limits
    if sent is None:
        sent = ctx.sync_sent
    round_number(round, ctx)
    client_name(client_id, 'client_id', ctx)
    text(reason, 'reason', ctx)
    if not ok:
        # A NACK may lack a clock: its numbers are not used.
        header_time(header, ctx, optional=True)
        time_near(sync_received, 'sync_received', ctx, optional=True)
        return
    number(offset, 'offset', -lim.max_offset, lim.max_offset)
    number(uncertainty, 'uncertainty', 0.0, lim.max_uncertainty)
    number(drift, 'drift', -lim.max_drift, lim.max_drift)
    sent_ack = header_time(header, ctx)
    time_near(sync_received, 'sync_received', ctx)
    if sync_received > sent_ack:
        raise Rejected('out_of_order', 'sync_received %.6f is after the '
                       'ACK was sent (%.6f)' % (sync_received, sent_ack),
                       'sync_received')
    if sent is not None:
        latency = sync_received - sent
        if not -lim.max_uncertainty <= latency <= lim.max_latency:
            raise Rejected('latency_out_of_range', 'dispatch latency %.3f s '
                           'is outside [%g, %g] s'
                           % (latency, -lim.max_uncertainty,
                              lim.max_latency), 'sync_received')


def capture_data(*, header: Any, round: Any, str_aft: Any, dur: Any,
                 clients: Any, ctx: Context) -> None:
    """/capture_data: the CM's order for one window (header.stamp: CR_T,
    when sent)."""
    lim = ctx.limits
    cr_t = header_time(header, ctx)
    round_number(round, ctx)
    number(str_aft, 'str_aft', lim.min_str_aft, lim.max_str_aft)
    duration(dur, 'dur', ctx)
    time_value(cr_t + str_aft + dur, 'header.stamp + str_aft + dur')
    names(clients, 'clients', ctx, empty=False)


def capture_command(*, header: Any, round: Any, start: Any, end: Any,
                    ctx: Context) -> None:
    """/<id>/capture_command: the CPM's order to its DPM (header.stamp:
    when ordered)."""
    header_time(header, ctx)
    round_number(round, ctx)
    time_near(start, 'start', ctx, ahead=ctx.limits.max_str_aft)
    time_value(end, 'end')
    duration(end - start, 'end - start', ctx)


def round_status(*, header: Any, round: Any, state: Any, reason: Any,
                 acked: Any, refused: Any, missing: Any, ctx: Context) -> None:
    """/round_status: the CM's state of a round (header.stamp: the
    change's global time, 0 when the server's clock is not synced)."""
    header_time(header, ctx, optional=True)
    round_number(round, ctx)
    choice(state, 'state', RoundState.ALL)
    text(reason, 'reason', ctx)
    for what, items in (('acked', acked), ('refused', refused),
                        ('missing', missing)):
        names(items, what, ctx)


def clock_state(*, client_id: Any, ok: Any, reason: Any, local_ref: Any,
                offset: Any, drift: Any, uncertainty: Any, samples: Any,
                round_trip: Any, ctx: Context) -> None:
    """/<id>/clock_state: a host's clock model, for the nodes of that host.

    ``ctx.local_now`` is the receiver's local now (the same host's clock):
    ``local_ref`` must lie near it and the model must map it to a valid
    global time.
    """
    lim = ctx.limits
    client_name(client_id, 'client_id', ctx)
    text(reason, 'reason', ctx)
    if not ok:
        return              # not used: the model is not ready
    number(offset, 'offset', -lim.max_offset, lim.max_offset)
    number(drift, 'drift', -lim.max_drift, lim.max_drift)
    number(uncertainty, 'uncertainty', 0.0, lim.max_uncertainty)
    # NaN: the burst just made failed (the model holds over).
    number(round_trip, 'round_trip', 0.0, lim.max_latency, nan=True)
    count(samples, 'samples', 2 ** 32 - 1)
    if samples < 1:
        raise Rejected('out_of_range', 'an ok clock with no samples',
                       'samples')
    local = Context(now=ctx.local_now, limits=lim)
    time_near(local_ref, 'local_ref', local)
    if ctx.local_now is not None:
        time_value(ctx.local_now + offset + drift * (ctx.local_now
                                                     - local_ref),
                   'global now by this model')


def client_result(*, header: Any, round: Any, client_id: Any, status: Any,
                  capture_start: Any, capture_end: Any, frames: Any,
                  frames_rejected: Any, frames_dropped: Any, coverage: Any,
                  first_frame_offset: Any, wake_lateness: Any, value: Any,
                  timing_uncertainty: Any, noise_floor: Any,
                  diagnostics: Any, noise_source: Any,
                  ctx: Context) -> None:
    """/client_result: a client's result of one window (header.stamp:
    when it was made, 0 when the client had no clock model).  A
    ``noise_floor`` that is not a finite number >= 0 does not reject the
    result: the decision module takes it as unknown and counts it;
    ``noise_source`` is '' or one of ``NoiseSource.ALL``."""
    lim = ctx.limits
    header_time(header, ctx, optional=True)
    round_number(round, ctx)
    client_name(client_id, 'client_id', ctx)
    choice(status, 'status', ResultStatus.ALL)
    time_near(capture_start, 'capture_start', ctx, ahead=lim.max_str_aft,
              behind=lim.max_dur)
    time_value(capture_end, 'capture_end')
    duration(capture_end - capture_start, 'capture_end - capture_start',
             ctx)
    for what, n in (('frames', frames), ('frames_rejected', frames_rejected),
                    ('frames_dropped', frames_dropped)):
        count(n, what, lim.max_frames)
    number(coverage, 'coverage', 0.0, 1.0)
    usable = status in ResultStatus.USABLE
    number(value, 'value', nan=not usable)
    number(first_frame_offset, 'first_frame_offset', -lim.max_dur,
           lim.max_dur, nan=True)
    number(wake_lateness, 'wake_lateness', -lim.max_dur, lim.max_dur,
           nan=True)
    number(timing_uncertainty, 'timing_uncertainty', 0.0, lim.max_dur,
           nan=True)
    if usable and frames == 0:
        raise Rejected('inconsistent', 'status %s with no frames' % status,
                       'frames')
    if noise_source:
        choice(noise_source, 'noise_source', NoiseSource.ALL)
    diagnostics = list(diagnostics)
    if len(diagnostics) > lim.max_diagnostics:
        raise Rejected('list_too_long', 'diagnostics has %d entries (limit '
                       '%d)' % (len(diagnostics), lim.max_diagnostics),
                       'diagnostics')
    for kv in diagnostics:
        for part in components(kv, ('key', 'value'), 'diagnostics'):
            text(part, 'diagnostics', ctx)


def decision(*, header: Any, round: Any, outcome: Any, winner: Any,
             clients: Any, scores: Any, reason: Any, window_end: Any,
             timing_uncertainty: Any, noise_floors: Any,
             ctx: Context) -> None:
    """/decision: the DM's verdict (header.stamp: when decided, 0 when
    the server's clock is not synced); ``noise_floors``: none, or one
    per client (NaN: unknown)."""
    header_time(header, ctx, optional=True)
    round_number(round, ctx)
    choice(outcome, 'outcome', Outcome.ALL)
    names(clients, 'clients', ctx)
    scores = list(scores)
    if len(scores) != len(clients):
        raise Rejected('wrong_length', '%d scores for %d clients'
                       % (len(scores), len(clients)), 'scores')
    for s in scores:
        number(s, 'scores', nan=True)
    noise_floors = list(noise_floors)
    if noise_floors and len(noise_floors) != len(clients):
        raise Rejected('wrong_length', '%d noise floors for %d clients'
                       % (len(noise_floors), len(clients)), 'noise_floors')
    for f in noise_floors:
        number(f, 'noise_floors', 0.0, nan=True)
    if outcome == Outcome.WINNER:
        count(winner, 'winner', len(clients))
        if winner < 1:
            raise Rejected('inconsistent', 'outcome winner without a '
                           'winner', 'winner')
    elif winner != 0:
        raise Rejected('inconsistent', 'outcome %s names winner %r'
                       % (outcome, winner), 'winner')
    text(reason, 'reason', ctx)
    time_value(window_end, 'window_end', optional=True)
    number(timing_uncertainty, 'timing_uncertainty', 0.0,
           ctx.limits.max_dur, nan=True)


def dpm_state(*, header: Any, client_id: Any, input: Any, samples: Any,
              sample_age: Any, rate: Any, refused: Any,
              refused_reason: Any, ctx: Context) -> None:
    """<id>/dpm_state: a DPM's heartbeat for its CPM (same host).

    ``header.stamp`` is the host's local clock, near ``ctx.local_now``;
    the sample age (NaN before the first sample) and the rate (NaN:
    unknown) are non-negative.
    """
    lim = ctx.limits
    time_near(header_stamp(header), 'header.stamp',
              Context(now=ctx.local_now, limits=lim))
    client_name(client_id, 'client_id', ctx)
    text(input, 'input', ctx)
    count(samples, 'samples', 2 ** 32 - 1)
    count(refused, 'refused', 2 ** 32 - 1)
    text(refused_reason, 'refused_reason', ctx)
    number(sample_age, 'sample_age', 0.0, lim.past + lim.future, nan=True)
    number(rate, 'rate', 0.0, 1e6, nan=True)
    if samples and math.isnan(sample_age):
        raise Rejected('inconsistent', '%d samples but no sample age'
                       % samples, 'sample_age')


# --- samples ----------------------------------------------------------------

def skeleton(*, header: Any, client_id: Any, user_id: Any, device_stamp: Any,
             positions: Any, orientations: Any, confidence: Any,
             frame_index: Any, frames_skipped: Any, sources: Any,
             ctx: Context) -> None:
    """/<id>/skeleton (and /<id>/captured): one tracked user's joints.

    ``header.stamp`` is global time, ``device_stamp`` the sensor's own
    clock (only representable: a device clock may start anywhere).  NaN
    positions (a joint not tracked) pass with ``nan_joints``; infinite or
    far ones do not.  Confidence is within [0, 1].  ``frame_index`` and
    ``frames_skipped`` are counts (0: unknown).  ``sources`` (a fused
    skeleton's views) are distinct view ids (graph names: ``robot1/cam``).
    """
    lim = ctx.limits
    time_near(header_stamp(header), 'header.stamp', ctx)
    client_name(client_id, 'client_id', ctx)
    count(user_id, 'user_id', 2 ** 32 - 1)
    count(frame_index, 'frame_index', 2 ** 32 - 1)
    count(frames_skipped, 'frames_skipped', 2 ** 32 - 1)
    time_value(device_stamp, 'device_stamp')
    for i, p in enumerate(array(positions, 'positions', NUM_JOINTS)):
        vector(p, 'positions[%d]' % i, lim.max_coordinate,
               nan=lim.nan_joints)
    for i, q in enumerate(array(orientations, 'orientations', NUM_JOINTS)):
        vector(q, 'orientations[%d]' % i, 1.0 + 1e-6,
               ('x', 'y', 'z', 'w'), nan=lim.nan_joints)
    for i, c in enumerate(array(confidence, 'confidence', NUM_JOINTS)):
        number(c, 'confidence[%d]' % i, 0.0, 1.0)
    names(sources, 'sources', ctx, graph=True)


def sample(*, header: Any, index: Any, value: Any, ctx: Context) -> None:
    """hri_sync/Sample: one numeric sample; its header.stamp is the
    sensor's clock; a NaN value is a missing one (the processor counts
    it), an infinite one is rejected."""
    time_value(header_stamp(header), 'header.stamp')
    count(index, 'index', 2 ** 32 - 1)
    number(value, 'value', nan=True)


class StampOrder:
    """Per-source order of sample stamps: a repeated stamp is rejected.

    A stamp that goes back is let through (a restarted sensor's clock
    does, and the device clock map starts over); one equal to the last
    of its source is the same sample twice or a broken clock.
    """

    def __init__(self) -> None:
        self.last: dict[str, float] = {}

    def check(self, source: str, t: float) -> None:
        """Raise Rejected if ``t`` repeats the last stamp of ``source``."""
        if self.last.get(source) == t:
            raise Rejected('stamp_repeated', 'stamp %.6f of %s repeats the '
                           'previous sample\'s' % (t, source), 'stamp')
        self.last[source] = t


# --- the robot's messages ---------------------------------------------------

def action_start(*, header: Any, round: Any, client_id: Any, action: Any,
                 scheduled: Any, offset: Any, true_time: Any, kind: Any,
                 event: Any, status: Any, reason: Any, tolerance: Any,
                 local_time: Any, ctx: Context) -> None:
    """~action_start of DJ Rob, the music and action_client: when an
    action began (header.stamp, global).  Empty kind and status: not
    judged (DJ Rob's, the music's)."""
    header_time(header, ctx)
    round_number(round, ctx)
    client_name(client_id, 'client_id', ctx)
    name(action, 'action', ctx)
    time_near(scheduled, 'scheduled', ctx)
    number(offset, 'offset', -ctx.limits.max_dur, ctx.limits.max_dur)
    time_value(true_time, 'true_time')
    choice(kind, 'kind', ('',) + Action.KINDS)
    choice(event, 'event', ('',) + Action.EVENTS)
    choice(status, 'status', ('',) + Action.STATUSES)
    text(reason, 'reason', ctx)
    if status in (Action.LATE, Action.FAILED) and not reason:
        raise Rejected('no_reason', 'status %s without a reason' % status,
                       'reason')
    number(tolerance, 'tolerance', 0.0, ctx.limits.max_dur)
    time_value(local_time, 'local_time', optional=True)


def action_end(*, header: Any, round: Any, client_id: Any, action: Any,
               kind: Any, event: Any, status: Any, reason: Any,
               started: Any, duration: Any, timeout: Any,
               ctx: Context) -> None:
    """~action_end of action_client: when an action that began ended
    (header.stamp, global): ``duration`` after ``started``, a FAILED or
    TIMEOUT end saying why."""
    header_time(header, ctx)
    round_number(round, ctx)
    client_name(client_id, 'client_id', ctx)
    name(action, 'action', ctx)
    choice(kind, 'kind', Action.KINDS)
    choice(event, 'event', Action.EVENTS)
    choice(status, 'status', ActionEnd.STATUSES)
    text(reason, 'reason', ctx)
    if status != ActionEnd.OK and not reason:
        raise Rejected('no_reason', 'status %s without a reason' % status,
                       'reason')
    time_near(started, 'started', ctx)
    number(duration, 'duration', 0.0, ctx.limits.max_dur)
    number(timeout, 'timeout', 0.0, ctx.limits.max_dur, nan=True)


def beat(*, header: Any, round: Any, index: Any, bar_beat: Any, bpm: Any,
         ctx: Context) -> None:
    """~beat of the music player (header.stamp: the beat's time)."""
    header_time(header, ctx)
    round_number(round, ctx)
    count(index, 'index', 2 ** 32 - 1)
    count(bar_beat, 'bar_beat', 255)
    number(bpm, 'bpm', 1.0, 1000.0)


def twist(*, linear: Any, angular: Any, ctx: Context) -> None:
    """geometry_msgs/Twist: a velocity command."""
    vector(linear, 'linear', ctx.limits.max_speed)
    vector(angular, 'angular', ctx.limits.max_speed)


def odometry(*, header: Any, child_frame_id: Any, pose: Any, twist: Any,
             ctx: Context) -> None:
    """nav_msgs/Odometry: the base's pose (finite, within max_coordinate
    of the origin; a unit orientation) and velocity.  Its stamp is the
    base's ROS time, only checked to be a time."""
    lim = ctx.limits
    time_value(header_stamp(header), 'header.stamp', optional=True)
    text(child_frame_id, 'child_frame_id', ctx)
    inner, cov = components(pose, ('pose', 'covariance'), 'pose')
    position, orientation = components(inner, ('position', 'orientation'),
                                       'pose.pose')
    vector(position, 'position', lim.max_coordinate)
    q = vector(orientation, 'orientation', 1.0 + 1e-6, ('x', 'y', 'z', 'w'))
    if abs(sum(c * c for c in q) - 1.0) > 1e-3:
        raise Rejected('malformed', 'orientation is not a unit quaternion',
                       'orientation')
    inner, _ = components(twist, ('twist', 'covariance'), 'twist')
    linear, angular = components(inner, ('linear', 'angular'), 'twist.twist')
    vector(linear, 'twist.linear', lim.max_speed)
    vector(angular, 'twist.angular', lim.max_speed)
    for c in array(cov, 'pose.covariance', 36):
        number(c, 'pose.covariance')


def enum_value(value: int, what: str, allowed: range) -> int:
    """A uint8 constant (an LED colour, a sound) out of ``allowed``."""
    count(value, what, 255)
    return choice(value, what, allowed)


def led(*, value: Any, ctx: Context) -> None:
    """hri_sync/Led (kobuki_msgs/Led): BLACK, GREEN, ORANGE or RED."""
    enum_value(value, 'value', range(4))


def sound(*, value: Any, ctx: Context) -> None:
    """hri_sync/Sound (kobuki_msgs/Sound): ON .. CLEANINGEND."""
    enum_value(value, 'value', range(7))


VALIDATORS: dict[str, Callable[..., None]] = {
    'hri_sync/SyncTime': sync_time,
    'hri_sync/SyncAck': sync_ack,
    'hri_sync/CaptureData': capture_data,
    'hri_sync/CaptureCommand': capture_command,
    'hri_sync/RoundStatus': round_status,
    'hri_sync/ClockState': clock_state,
    'hri_sync/ClientResult': client_result,
    'hri_sync/DpmState': dpm_state,
    'hri_sync/Decision': decision,
    'hri_sync/Skeleton': skeleton,
    'hri_sync/Sample': sample,
    'hri_sync/ActionStart': action_start,
    'hri_sync/ActionEnd': action_end,
    'hri_sync/Beat': beat,
    'hri_sync/Led': led,
    'hri_sync/Sound': sound,
    'geometry_msgs/Twist': twist,
    'nav_msgs/Odometry': odometry,
}


def check(msg_type: str, fields: dict[str, Any], ctx: Context) -> None:
    """Validate a message of ROS type ``msg_type`` given as a dict of its
    fields; raises Rejected, or KeyError for a type without a check."""
    try:
        validator = VALIDATORS[msg_type]
    except KeyError:
        raise KeyError('no validator for %s' % msg_type)
    validator(ctx=ctx, **fields)
