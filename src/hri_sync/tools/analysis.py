"""Every figure of a session report, computed from a recording (no ROS).

``summarize(session)`` turns a ``hri_sync.tools.session.Session`` into
one JSON-ready dict: the clients' clock models over time, each round's
schedule, ACKs, results, start skew, error bound, first frames (the
paper's Figure 5), each score building up over the window, the decision
recomputed from the captured frames, what DJ Rob and the music did, and a
verdict. The page's tables and plots are drawn from this dict only, so
``summary.json`` holds every figure shown. Times are seconds on the
global clock unless a key says ``_ms``; NaN becomes None (JSON null).
"""
import math

import numpy as np

from hri_sync.dance_off.expressiveness import (DEFAULT_MIN_CONFIDENCE,
                                               RunningExpressiveness)
from hri_sync.dance_off.joints import NUM_JOINTS
from hri_sync.dance_off import verify
from hri_sync.clock.skew import client_timing, percentiles, start_skew
from hri_sync.tools.robot_check import check_robot, deg, poses
from hri_sync.tools.session import (field_or_nan, secs, server_clock,
                                    stamp_of)

DEFAULT_BEARINGS = [30.0, -30.0]
DEFAULT_DISTANCE = 1.5
# A recording without /dance_off/config, or with an older one, was
# decided by the threshold rule.
DEFAULT_RULE = {'min_expressiveness': 1.0, 'tie_margin': 0.0,
                'on_missing': 'partial', 'decision_rule': 'threshold',
                'noise_factor': 3.0}
FIG5_BEFORE, FIG5_AFTER = 0.2, 0.4     # s around the window start
BUILD_UP_POINTS = 60
AFTER_WINDOW_SLACK = 0.2               # s after the window end, bag time
ROBOT_ID, SERVER_ID = 'dj_rob', 'server'
# The per-window error bound of ClientResult and Decision, by the names
# it has had.
ERROR_BOUND_FIELDS = ('error_bound', 'timing_uncertainty')


def error_bound(msg):
    """A result's or decision's error bound (s), NaN where the recorded
    message has none."""
    for name in ERROR_BOUND_FIELDS:
        if hasattr(msg, name):
            return field_or_nan(msg, name)
    return math.nan


def ms(x):
    return x * 1e3 if x is not None and math.isfinite(x) else math.nan


def clean(obj, digits=6):
    """``obj`` with NaN/inf as None, floats rounded, numpy as Python."""
    if isinstance(obj, dict):
        return {str(k): clean(v, digits) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [clean(v, digits) for v in obj]
    if isinstance(obj, (np.floating, float)):
        v = float(obj)
        return round(v, digits) if math.isfinite(v) else None
    if isinstance(obj, np.integer):
        return int(obj)
    if isinstance(obj, np.bool_):
        return bool(obj)
    return obj


def _truth(msg):
    """(true time, id) of a captured sample whose sensor stamps the true
    clock: Skeleton.device_stamp, or a reference Sample's value/index."""
    if hasattr(msg, 'device_stamp'):
        t = secs(msg.device_stamp)
        return t, t
    return msg.value, msg.index


def _is_skeleton(frames):
    return bool(frames) and hasattr(frames[0][1], 'positions')


def _window(frames, start, end):
    """Frames with start <= stamp < end (frames sorted by stamp)."""
    stamps = [f[0] for f in frames]
    lo = np.searchsorted(stamps, start, 'left')
    hi = np.searchsorted(stamps, end, 'left')
    return frames[lo:hi]


def _min_confidence(result):
    for kv in getattr(result, 'diagnostics', []):
        if kv.key == 'min_confidence':
            try:
                return float(kv.value)
            except ValueError:
                break
    return DEFAULT_MIN_CONFIDENCE


def skeleton_arrays(frames):
    """(stamps (N,), positions (N, 15, 3), confidence (N, 15)) of
    Skeleton frames [(stamp, msg)]; malformed frames are skipped."""
    stamps, pos, conf = [], [], []
    for s, m in frames:
        p = [(q.x, q.y, q.z) for q in m.positions]
        c = [float(x) for x in m.confidence]
        if len(p) != NUM_JOINTS or len(c) != NUM_JOINTS:
            continue
        stamps.append(s)
        pos.append(p)
        conf.append(c)
    return (np.asarray(stamps, float),
            np.asarray(pos, float).reshape(-1, NUM_JOINTS, 3),
            np.asarray(conf, float).reshape(-1, NUM_JOINTS))


def build_up(frames, start, dur, min_confidence, points=BUILD_UP_POINTS):
    """Cumulative expressiveness over the window: the score of the frames
    up to each of ``points`` instants, over the whole window's T (so the
    last point is the round's score). Returns {'t': [s], 'value': []}."""
    stamps, pos, conf = skeleton_arrays(frames)
    if not len(stamps):
        return {'t': [], 'value': []}
    order = np.argsort(stamps, kind='stable')           # NaN stamps last
    stamps, pos, conf = stamps[order], pos[order], conf[order]
    ts = np.linspace(0.0, dur, points + 1)[1:]
    run = RunningExpressiveness(NUM_JOINTS, min_confidence)
    values, added = [], 0
    for t in ts:           # one pass: each point adds the frames up to it
        k = int(np.searchsorted(stamps, start + t, 'right'))
        for i in range(added, k):
            run.add(float(stamps[i]), pos[i], conf[i])
        added = max(added, k)
        values.append(run.score(dur).value if k else 0.0)
    return {'t': ts.tolist(), 'value': values}


def clock_series(session, t0):
    """{client: series} of every recorded ClockState: time (s from t0, the
    model's reference instant in global time), offset (ms), drift (ppm),
    uncertainty (ms), NTP round trip (ms; NaN where not recorded), ok."""
    out = {}
    for client, states in sorted(session.clock_states.items()):
        ser = {'t': [], 'offset_ms': [], 'drift_ppm': [],
               'uncertainty_ms': [], 'round_trip_ms': [], 'ok': [],
               'samples': []}
        for r in states:
            m = r.msg
            g = m.local_ref + m.offset if m.ok else math.nan
            ser['t'].append(g - t0 if math.isfinite(g) else math.nan)
            ser['offset_ms'].append(ms(m.offset) if m.ok else math.nan)
            ser['drift_ppm'].append(m.drift * 1e6 if m.ok else math.nan)
            ser['uncertainty_ms'].append(ms(m.uncertainty) if m.ok
                                         else math.nan)
            ser['round_trip_ms'].append(ms(field_or_nan(m, 'round_trip')))
            ser['ok'].append(bool(m.ok))
            ser['samples'].append(int(m.samples))
        out[client] = ser
    return out


def decision_rule(config, overrides=None):
    """The decision module's rule: the defaults, then what the recording's
    /dance_off/config says, then ``overrides`` that are not None."""
    rule = dict(DEFAULT_RULE)
    rule.update({k: config[k] for k in DEFAULT_RULE if k in config})
    rule.update({k: v for k, v in (overrides or {}).items()
                 if v is not None})
    return rule


def _ack_row(ack, sync):
    m = ack.msg
    sync_t = stamp_of(sync.msg) if sync is not None else math.nan
    return {'ok': bool(m.ok), 'reason': m.reason,
            'offset_s': m.offset, 'uncertainty_ms': ms(m.uncertainty),
            'drift_ppm': m.drift * 1e6,
            'dispatch_ms': ms(secs(m.sync_received) - sync_t),
            'ack_ms': ms(stamp_of(m) - sync_t)}


def _none_if_nan(x):
    """None for NaN (unknown, or not recorded), else ``x``."""
    return None if math.isnan(x) else x


def _result_row(res, frames, truth):
    m = res.msg
    row = {'status': m.status, 'frames': m.frames,
           'rejected': m.frames_rejected, 'dropped': m.frames_dropped,
           'coverage': m.coverage,
           'first_frame_offset_ms': ms(m.first_frame_offset),
           'wake_lateness_ms': ms(m.wake_lateness), 'value': m.value,
           'noise_floor': _none_if_nan(field_or_nan(m, 'noise_floor')),
           'noise_source': getattr(m, 'noise_source', '') or None,
           'error_bound_ms': ms(error_bound(m)),
           'captured': len(frames), 'clock_error_ms': math.nan}
    if truth and frames:
        kept = [(s, *_truth(f)) for s, f in frames]
        row['clock_error_ms'] = ms(client_timing('', kept).clock_error)
    return row


def _fig5(frames, start):
    lo, hi = start - FIG5_BEFORE, start + FIG5_AFTER
    return [ms(s - start) for s, _ in frames if lo <= s < hi]


def has_robot(session):
    """True if the recording shows a robot (odometry, commands or its
    clock)."""
    robot_id = session.config.get('robot_id', ROBOT_ID)
    return bool(session.odom or session.cmd_vel
                or robot_id in session.clock_states)


def robot_places(config):
    """(bearings in deg, distance in m, where they come from)."""
    bearings = [float(b) for b in config.get('participant_bearings',
                                             DEFAULT_BEARINGS)]
    distance = float(config.get('participant_distance', DEFAULT_DISTANCE))
    return bearings, distance, ('/dance_off/config'
                                if 'participant_bearings' in config
                                else 'default (not recorded)')


def check_round_robot(session, rnd, clock, pose_list, tolerance):
    """The RobotCheck of a decided round (see robot_check.check_robot);
    None if the round has no decision or began before the recording."""
    if rnd.decision is None or session.began_before(rnd, clock):
        return None
    d = rnd.decision.msg
    robot_id = session.config.get('robot_id', ROBOT_ID)
    scheduled = rnd.capture is not None and \
        robot_id in rnd.capture.msg.clients
    after = (clock.to_bag(rnd.end) if rnd.capture is not None
             else rnd.first_t) + AFTER_WINDOW_SLACK
    bearings, distance, _ = robot_places(session.config)
    return check_robot(rnd.n, d.outcome, d.winner, rnd.decision.t, after,
                       session.next_round_t(rnd.n), pose_list,
                       session.cmd_vel, bearings,
                       distance if distance > 0 else None, tolerance,
                       scheduled)


def _robot(session, rnd, clock, pose_list, tolerance):
    """Robot check and heading series of one round (None: no robot)."""
    if not has_robot(session):
        return None
    bearings, distance, source = robot_places(session.config)
    out = {'bearings_deg': bearings, 'distance_m': distance,
           'bearings_source': source}
    chk = check_round_robot(session, rnd, clock, pose_list, tolerance)
    if chk is not None:
        out.update({'expected': chk.expected, 'ok': chk.ok,
                    'verdict': chk.verdict, 'problems': chk.problems,
                    'final_heading_deg': chk.final_heading,
                    'target_deg': chk.target, 'error_deg': chk.error,
                    'travel_m': chk.travel, 'turn_deg': chk.turn,
                    'gesture_latency_ms': ms(chk.gesture_latency),
                    'gesture_start': clock.to_global(chk.gesture_start)
                    - rnd.start if rnd.capture is not None else math.nan})
    else:
        out.update({'ok': None, 'verdict': 'robot: n/a (no decision)',
                    'problems': []})
    # Heading over the round, relative to the window start (global).
    until = session.next_round_t(rnd.n)
    lo = rnd.first_t - 0.5
    hi = min(until, session.end)
    seg = [p for p in pose_list if lo <= p.t <= hi]
    step = max(1, len(seg) // 600)
    base = rnd.start if rnd.capture is not None else clock.to_global(lo)
    out['heading'] = {
        't': [clock.to_global(p.t) - base for p in seg[::step]],
        'deg': [deg(p.yaw) for p in seg[::step]]}
    if rnd.decision is not None:
        out['decision_t'] = clock.to_global(rnd.decision.t) - base
    return out


def _starts(rnd):
    """Dance and music starts against the schedule."""
    out = {}
    for (client, action), m in sorted(rnd.starts.items()):
        sched = secs(m.scheduled)
        out[action] = {'client': client,
                       'offset_ms': ms(m.offset),
                       'true_offset_ms': ms(secs(m.true_time) - sched),
                       'scheduled_vs_window_ms': ms(sched - rnd.start)}
    return out


def _cut_off(session, rnd, clock):
    """How the recording cut the round: 'end' (no decision recorded),
    'start' (its window began before the recording: a later part of a
    split one, or a latched decision repeated), or False (whole)."""
    if rnd.decision is None:
        return 'end'
    return 'start' if session.began_before(rnd, clock) else False


def summarize_round(session, rnd, clock, pose_list, rule, truth_clients,
                    tolerance):
    """The figures of one round (see the module docstring)."""
    # Over 80 lines: one dict of the round's figures, field by field.
    d = rnd.decision.msg if rnd.decision is not None else None
    row = {'round': rnd.n, 'cut_off': _cut_off(session, rnd, clock),
           'duplicates': list(rnd.duplicates)}
    sync = rnd.sync
    if rnd.capture is not None:
        c = rnd.capture.msg
        row.update({'cr_t': stamp_of(c), 'str_aft': c.str_aft,
                    'dur': c.dur, 'start': rnd.start,
                    'participants_scheduled': list(c.clients)})
        if sync is not None:
            row['ack_round_ms'] = ms(stamp_of(c) - stamp_of(sync.msg))
    row['acks'] = {k: _ack_row(a, sync) for k, a in sorted(rnd.acks.items())}
    row['aborted_reason'] = rnd.aborted_reason
    participants = rnd.participants
    row['participants'] = participants
    clients, timings, fig5, raw5, curves = {}, [], {}, {}, {}
    for client in participants:
        frames = session.captured.get(client, [])
        if rnd.capture is not None:
            frames = _window(frames, rnd.start, rnd.end)
        res = rnd.results.get(client)
        truth = client in truth_clients
        if res is None:
            clients[client] = {'status': 'missing (no result recorded)'}
            continue
        clients[client] = _result_row(res, frames, truth)
        if truth and frames:
            timings.append(client_timing(client, [(s, *_truth(f))
                                                  for s, f in frames]))
        if rnd.capture is None:
            continue
        fig5[client] = _fig5(frames, rnd.start)
        raw = session.raw.get(client, [])
        if raw:
            raw5[client] = _fig5(raw, rnd.start)
        if _is_skeleton(frames):
            curves[client] = build_up(frames, rnd.start, rnd.capture.msg.dur,
                                      _min_confidence(res.msg))
    row['clients'] = clients
    skew = start_skew(timings)
    row['start_skew_ms'] = ms(skew)
    if math.isfinite(skew):
        row['start_skew_note'] = ('clock errors of %s against their '
                                  'sensors\' true-clock stamps'
                                  % ', '.join(t.client_id for t in timings))
    elif not truth_clients:
        row['start_skew_note'] = ('n/a: the recording does not say which '
                                  'sensors stamp the true clock')
    else:
        row['start_skew_note'] = ('n/a: fewer than two clients with '
                                  'true-clock frames')
    bounds = [v['error_bound_ms'] for v in clients.values()
              if 'error_bound_ms' in v]
    bound = ms(error_bound(d))
    if not math.isfinite(bound) and any(map(math.isfinite, bounds)):
        bound = max(b for b in bounds if math.isfinite(b))
    row['error_bound_ms'] = bound
    row['fig5'] = fig5
    row['fig5_raw'] = raw5
    row['build_up'] = curves
    if d is not None:
        decided = stamp_of(d)       # 0: the server's clock was not synced
        row['decision'] = {
            'outcome': d.outcome, 'winner': d.winner,
            'winner_client': participants[d.winner - 1]
            if 1 <= d.winner <= len(participants) else None,
            'reason': d.reason, 'scores': list(d.scores),
            'stamp': decided,
            'latency_ms': ms(decided - rnd.end) if decided > 0
            else math.nan}
        row['recomputed'] = _recompute(session, rnd, rule)
    row['starts'] = _starts(rnd)
    row['beats'] = len(rnd.beats)
    robot = _robot(session, rnd, clock, pose_list, tolerance)
    if robot is not None:
        row['robot'] = robot
    row['ok'], row['verdict'] = _verdict(row)
    return row


def results_at_decision(rnd):
    """({client: ClientResult} the decision module had, {client: s} of
    results it did not have: recorded after the decision, which carries no
    score for them (a result that arrived past the DM's deadline)."""
    d = rnd.decision
    scores = dict(zip(d.msg.clients, d.msg.scores)) if d else {}
    used, late = {}, {}
    for client, r in rnd.results.items():
        if d is not None and r.t > d.t and client in scores and \
                not math.isfinite(scores[client]):
            late[client] = r.t - d.t
        else:
            used[client] = r.msg
    return used, late


def recompute(session, rnd, rule):
    """(verify.RoundCheck, late results) of a decided round, or (None,
    late) when there are no captured skeleton frames to recompute from."""
    used, late = results_at_decision(rnd)
    frames = {c: session.captured.get(c, []) for c in rnd.participants}
    if not any(_is_skeleton(f) for f in frames.values()):
        return None, late
    return verify.check_round(rnd.decision.msg, used, frames, rule,
                              rnd.aborted_reason), late


def _recompute(session, rnd, rule):
    chk, late = recompute(session, rnd, rule)
    out = {'late_results_s': late}
    if chk is None:
        out.update({'reproduced': None, 'note': 'n/a: no captured skeleton '
                    'frames to recompute the scores from', 'problems': []})
        return out
    problems = list(chk.problems) + [
        '%s: %s' % (c.client, p) for c in chk.clients for p in c.problems]
    out.update({'reproduced': chk.ok, 'outcome': chk.outcome_recomputed,
                'winner': chk.winner_recomputed, 'problems': problems,
                'values': {c.client: c.value_recomputed
                           for c in chk.clients}})
    return out


def _verdict(row):
    """(ok, one line) of a round; ok is None for a round the recording
    cut off (not checked)."""
    if row['cut_off'] == 'start':
        return None, ('CUT OFF: its window began before the recording; '
                       'its decision is here, not all its frames')
    if row['cut_off']:
        return None, ('CUT OFF: the recording holds no decision for this '
                      'round')
    d, rec = row['decision'], row['recomputed']
    who = ' participant %d (%s)' % (d['winner'], d['winner_client']) \
        if d['winner'] else ''
    if d['winner'] and len(row.get('participants') or ()) == 1:
        who = ' (%s, the only participant: nothing compared)' % (
            d['winner_client'])
    parts = ['%s%s' % (d['outcome'], who)]
    ok = True
    if rec['reproduced'] is None:
        parts.append('decision not recomputed (%s)' % rec['note'])
    elif rec['reproduced']:
        parts.append('decision reproduced from the captured frames')
    else:
        ok = False
        parts.append('DECISION NOT REPRODUCED: ' + '; '.join(
            rec['problems']))
    if rec.get('late_results_s'):
        parts.append('result(s) of %s recorded %s after the decision, '
                     'which was made without them' % (
                         ', '.join(sorted(rec['late_results_s'])),
                         ', '.join('%.2f s' % v for _, v in sorted(
                             rec['late_results_s'].items()))))
    robot = row.get('robot')
    if robot is not None:
        parts.append(robot['verdict'])
        if robot['ok'] is False:
            ok = False
    return ok, '; '.join(parts)


def summarize(session, rule_overrides=None, tolerance=10.0):
    """The whole report of one session as a dict (see the module doc)."""
    config = session.config
    rule = decision_rule(config, rule_overrides)
    truth = config.get('truth_clients')
    truth_clients = set(truth) if isinstance(truth, list) else set()
    clock = server_clock(session, SERVER_ID)
    syncs = [stamp_of(r.sync.msg) for r in session.rounds.values()
             if r.sync is not None]
    t0 = min(syncs) if syncs else clock.to_global(session.start)
    pose_list = poses(session.odom)
    rounds = [summarize_round(session, session.rounds[n], clock, pose_list,
                              rule, truth_clients, tolerance)
              for n in sorted(session.rounds)]
    out = {'bag': session.path, 't0': t0,
           'duration_s': session.end - session.start,
           'topics': {t: k for t, k in sorted(session.topics.items())},
           'old_types': {k: {'bag': v[0], 'package': v[1]}
                         for k, v in session.old_types.items()},
           'pre_header_types': list(session.pre_header),
           'config': config, 'decision_rule': rule,
           'truth_clients': sorted(truth_clients),
           'heading_tolerance_deg': tolerance,
           'recorder_clock': ('the server\'s clock model (/server/'
                              'clock_state)' if clock.known else
                              'bag time taken as global time (no '
                              '/server/clock_state recorded)'),
           'clocks': clock_series(session, t0),
           'rounds': rounds, 'calibration': calibration(session),
           'missing': missing_sections(session)}
    if session.config_error:
        out['missing'].append({'section': 'configuration',
                               'reason': session.config_error})
    if pose_list:
        step = max(1, len(pose_list) // 3000)
        out['heading'] = {
            't': [clock.to_global(p.t) - t0 for p in pose_list[::step]],
            'deg': [deg(p.yaw) for p in pose_list[::step]]}
    out['totals'] = totals(rounds)
    return out


def calibration(session):
    """The calibration window before round 1 (None when the recording has
    none): its global window, each participant's calibration result
    (status, still score, the noise floor it set and its source) and the
    decision module's answer. A recording that starts after the window
    (a later part of a split one: its latched answer repeated) has no
    window: ``dur_s`` None."""
    cal = session.calibration
    if cal is None:
        return None
    known = all(t is not None and math.isfinite(t)
                for t in (cal.start, cal.end))
    return {'start': cal.start if known else None,
            'dur_s': cal.end - cal.start if known else None,
            'clients': {c: {'status': r.msg.status,
                            'value': _none_if_nan(r.msg.value),
                            'noise_floor': _none_if_nan(field_or_nan(
                                r.msg, 'noise_floor')),
                            'noise_source': getattr(
                                r.msg, 'noise_source', '') or None}
                        for c, r in sorted(cal.results.items())},
            'outcome': cal.decision.msg.outcome if cal.decision else None,
            'reason': cal.decision.msg.reason if cal.decision else None}


def calibration_text(summary):
    """One line of ``calibration``'s summary (None: none recorded)."""
    if summary is None:
        return 'calibration: none recorded (the noise rule trusts no ' \
            'uncalibrated floor)'

    def g(x):
        return 'n/a' if x is None else '%.4g' % x
    clients = '; '.join(
        '%s %s, still score %s, noise floor %s (%s)' % (
            c, r['status'], g(r['value']), g(r['noise_floor']),
            r['noise_source'] or 'n/a')
        for c, r in summary['clients'].items()) or 'no result recorded'
    window = ('window before this recording' if summary['dur_s'] is None
              else '%.1f s window' % summary['dur_s'])
    return 'calibration: %s; %s; answer: %s' % (
        window, clients, summary['outcome'] or 'none recorded')


def totals(rounds):
    """Session totals: rounds, decisions reproduced, robot correct,
    start skew and error bound percentiles."""
    decided = [r for r in rounds if not r['cut_off']]
    reproduced = [r for r in decided if r['recomputed']['reproduced']]
    robot = [r for r in decided if r.get('robot', {}).get('ok')
             is not None]
    robot_ok = [r for r in robot if r['robot']['ok']]
    skews = [_f(r['start_skew_ms']) for r in rounds]
    bounds = [_f(r['error_bound_ms']) for r in rounds]
    return {'rounds': len(rounds), 'decided': len(decided),
            'cut_off': [r['round'] for r in rounds if r['cut_off']],
            'reproduced': len(reproduced),
            'recomputed': sum(1 for r in decided
                              if r['recomputed']['reproduced'] is not None),
            'robot_checked': len(robot), 'robot_ok': len(robot_ok),
            'ok': all(r['ok'] for r in decided),
            'outcomes': _count(r['decision']['outcome'] for r in decided),
            'start_skew_ms': percentiles(skews, (50, 99)),
            'error_bound_ms': percentiles(bounds, (50, 99))}


def reproduced_text(t):
    """'N/M decisions reproduced' of ``totals`` ``t``, or why none was
    recomputed (no skeleton frames: not a dance-off)."""
    if t['decided'] and not t['recomputed']:
        return 'decisions not recomputed (no captured skeleton frames)'
    return '%d/%d decisions reproduced' % (t['reproduced'], t['recomputed'])


def _f(v):
    """A summary number (None after ``clean``) as a float."""
    return math.nan if v is None else float(v)


def _count(items):
    out = {}
    for i in items:
        out[i] = out.get(i, 0) + 1
    return out


SECTIONS = [
    # (section, what it needs, a predicate over the session, why missing)
    ('Rounds: schedule and ACKs', 'hri_sync/CaptureData and SyncAck',
     lambda s: s.has('hri_sync/CaptureData')),
    ('Results: frames, coverage, first frames',
     'hri_sync/ClientResult on /client_result',
     lambda s: s.has('hri_sync/ClientResult')),
    ('Decisions and verdicts', 'hri_sync/Decision on /decision',
     lambda s: s.has('hri_sync/Decision')),
    ('Figure 5, score build-up, recomputed decisions, start skew',
     'captured skeleton frames (/<client>/captured), as a dance-off '
     'records',
     lambda s: bool(s.captured)),
    ('Clocks: offset, drift, uncertainty',
     'hri_sync/ClockState (/<client>/clock_state)',
     lambda s: bool(s.clock_states)),
    ('NTP round trips', 'ClockState.round_trip (in recordings '
     'made since ClockState carries it)',
     lambda s: any(hasattr(r.msg, 'round_trip')
                   for v in s.clock_states.values() for r in v)),
    ('Error bound', 'per-window error bound in ClientResult/Decision '
     '(%s)' % ' or '.join(ERROR_BOUND_FIELDS),
     lambda s: any(hasattr(r.msg, f) for f in ERROR_BOUND_FIELDS
                   for rnd in s.rounds.values()
                   for r in list(rnd.results.values())
                   + ([rnd.decision] if rnd.decision else []))),
    ('Start skew (true time)', 'truth_clients in /dance_off/config',
     lambda s: isinstance(s.config.get('truth_clients'), list)),
    ('DJ Rob: heading and gesture', 'nav_msgs/Odometry (/odom) and the '
     'velocity commands (/mobile_base/commands/velocity)',
     lambda s: bool(s.odom) and bool(s.cmd_vel)),
    ('DJ Rob and music: start against the schedule',
     'hri_sync/ActionStart (/dj_rob/action_start, /music/action_start)',
     lambda s: s.has('hri_sync/ActionStart')),
]


def missing_sections(session):
    """[{'section', 'reason'}] of the report's sections the recording
    cannot fill, and why."""
    out = []
    other = sorted('%s (%s)' % (t, k) for t, k in session.topics.items()
                   if t.endswith('/captured') and k != 'hri_sync/Skeleton')
    for section, needs, present in SECTIONS:
        if not present(session):
            reason = 'the recording has no %s' % needs
            if section.startswith('Figure 5') and other:
                reason = ('not a dance-off: its captured frames are not '
                          'skeletons (%s)' % ', '.join(other))
            out.append({'section': section, 'reason': reason})
    return out


def robot_lines(session, tolerance):
    """(lines, ok) of DJ Rob's behaviour after each decided round."""
    if not has_robot(session):
        return ['robot: no DJ Rob in this recording (no /odom, commands '
                'or its clock): not checked'], True
    clock = server_clock(session)
    pose_list = poses(session.odom)
    bearings, distance, source = robot_places(session.config)
    lines = ['robot: participants at %s deg, %.2f m (%s); tolerance %.1f '
             'deg' % (', '.join('%+.1f' % b for b in bearings), distance,
                      source, tolerance)]
    ok = True
    for n in sorted(session.rounds):
        chk = check_round_robot(session, session.rounds[n], clock,
                                         pose_list, tolerance)
        if chk is None:
            continue
        lines.append('%5d robot: expected to %s%s: %s' % (
            n, chk.expected, ' (%s)' % chk.note if chk.note and chk.ok
            is not None else '', chk.verdict))
        if chk.ok is False:
            ok = False
    return lines, ok
