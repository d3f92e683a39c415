"""Figures of the start-skew benches from their recorded rounds (no ROS).

``bench/sync_skew.py`` and ``bench/multihost.py`` record every round (a
``RoundLog`` record and the arrival times their recorder kept) and know the
clock each client was given (``harness.FakeClock``); this turns them into
per-round figures (``analyse_round``) and the run's JSON object
(``summarize``).  Messages are read by their fields only.

A sample's stamp error (global stamp - true time) splits into the client's
**clock error** (its clock model's global time against the truth, at the
window start) and what is left, its **delivery delay**: from the sensor's
true send time to the DPM's stamp with arrival stamps, the device clock
map's built-in offset with device stamps.  The **start skew** is the spread
over the clients of their stamp error at the window start (the minimum
over the first samples), i.e. of both together.
"""
import math
from collections import Counter

from hri_sync.clock.model import ClockModel
from hri_sync.wire.protocol import Capture
from hri_sync.clock.skew import client_timing, percentiles, start_skew
from hri_sync.wire.vocabulary import Outcome, ResultStatus

from .harness import ms

ABORTED = Outcome.ABORTED
OK = ResultStatus.OK


def fail(failures, kind, fmt, *args):
    """Append a failure (kind, note) to ``failures``."""
    failures.append((kind, fmt % args))


def median(values):
    """The nearest-rank median, None for none."""
    return percentiles(values)['p50'] if values else None


def mean_ms(values):
    """Mean of seconds in ms (None for none)."""
    return round(sum(values) / len(values) * 1e3, 4) if values else None


def spread(values):
    """max - min of ``values`` (at least two), else None."""
    values = list(values)
    return max(values) - min(values) if len(values) >= 2 else None


def model_error(state, clock, true):
    """Error (s) of a client's published clock model ``state`` (a
    ClockState) at true time ``true``, for a client on FakeClock
    ``clock`` and a global clock that is the true clock.  Raises
    ValueError when the state's values are unusable."""
    model = ClockModel.from_state(state.local_ref, state.offset, state.drift,
                                  state.uncertainty)
    return model.to_global(clock.local(true)) - true


def analyse_round(n, rec, log_round, clocks, failures, same_sensor=True):
    """Figures of round ``n`` as a dict; failure notes appended to
    ``failures``.

    ``rec``: the recorder's arrival times and states (``sync``,
    ``ack_arrival``, ``status``, ``clock_states``); ``log_round``: the
    RoundLog record of the round or None; ``clocks``: {client: FakeClock};
    ``same_sensor``: every client reads one sensor, so whether they kept
    the same first sample is a figure.
    """
    out = {'round': n}
    statuses = rec.status.get(n, [])
    aborted = [s for s in statuses if s.state == ABORTED]
    decision = log_round['decision'] if log_round else None
    capture = log_round['capture'] if log_round else None
    if aborted:
        reason = aborted[-1].reason
        fail(failures, 'aborted', '%s', reason if reason.startswith(
            'round %d ' % n) else 'round %d aborted: %s' % (n, reason))
        out['aborted'] = aborted[-1].reason
    if log_round is None or n not in rec.sync:
        fail(failures, 'never_started',
             'round %d never started (no sync_time seen)', n)
        out['missing'] = True
        return out
    clients = sorted(clocks)
    acks = log_round['acks']
    for c in clients:
        if c not in acks:
            fail(failures, 'missing_ack', 'round %d: no ACK from %s', n, c)
        elif not acks[c].ok:
            fail(failures, 'nack', 'round %d: NACK from %s: %s', n, c,
                 acks[c].reason)
    arrivals = rec.ack_arrival.get(n, {})
    if all(c in arrivals for c in clients):
        out['ack_round'] = max(arrivals.values()) - rec.sync[n][0]
    out['ack_offset_error'] = []
    for c, a in acks.items():
        if c in clocks and a.ok and math.isfinite(a.offset):
            error = a.offset - clocks[c].offset_at(
                a.header.stamp.to_sec())
            out['ack_offset_error'].append(abs(error))
            out.setdefault('ack_offset_signed', {})[c] = error
    if decision is None:
        fail(failures, 'no_decision', 'round %d: no decision', n)
    elif decision.outcome == ABORTED and not aborted:
        fail(failures, 'aborted', 'round %d: decision aborted: %s', n,
             decision.reason)
    if capture is None:
        if not aborted:
            fail(failures, 'no_capture_data', 'round %d: no capture_data',
                 n)
        return out
    out['capture_order'] = (capture.header.stamp.to_sec()
                            - rec.sync[n][1].header.stamp.to_sec())
    out['str_aft'] = capture.str_aft
    results = log_round['results']
    timings = []
    out['wake'], out['frames'] = [], []
    for c in capture.clients:
        r = results.get(c)
        if r is None:
            fail(failures, 'missing_result', 'round %d: no result from %s',
                 n, c)
        else:
            if r.status != OK:
                why = ['%d frames, coverage %.2f' % (r.frames, r.coverage)]
                why += ['%s=%s' % (kv.key, kv.value) for kv in r.diagnostics
                        if kv.key in ('reason', 'error')]
                fail(failures, 'result_' + r.status,
                     'round %d: %s result %s (%s)', n, c, r.status,
                     ', '.join(why))
            out['frames'].append(r.frames)
            if math.isfinite(r.wake_lateness):
                out['wake'].append(r.wake_lateness)
        t = client_timing(c, log_round['captured'].get(c, []))
        if not t.samples:
            fail(failures, 'no_samples',
                 'round %d: no captured samples from %s', n, c)
        timings.append(t)
    missing_clients = [c for c in clients if c not in capture.clients]
    if missing_clients:
        fail(failures, 'quorum', 'round %d: captured without %s (quorum)',
             n, ','.join(missing_clients))
    start = Capture.from_msg(capture).start
    out['model_errors'] = {}
    for c in capture.clients:
        states = [m for t, m in rec.clock_states.get(c, []) if t < start]
        if c in clocks and states:
            try:
                out['model_errors'][c] = model_error(states[-1], clocks[c],
                                                     start)
            except ValueError as e:
                fail(failures, 'bad_clock_state', 'round %d: %s: %s', n, c,
                     e)
    if len(out['model_errors']) >= 2:
        out['model_skew'] = spread(out['model_errors'].values())
    out['errors'] = {t.client_id: t.clock_error for t in timings
                     if math.isfinite(t.clock_error)}
    # Delivery: the stamp error less the clock error, per sample, and at
    # the window start (the part of each client's start error it makes).
    out['delays'] = {
        c: [g - t - e for g, t, _ in log_round['captured'].get(c, [])]
        for c, e in out['model_errors'].items()}
    out['delivery'] = {c: out['errors'][c] - e
                       for c, e in out['model_errors'].items()
                       if c in out['errors']}
    if len(out['errors']) == len(clients):
        out['skew'] = start_skew(timings)
        if same_sensor:
            out['same_first'] = len({t.first_index for t in timings}) == 1
    if len(out['delivery']) == len(clients) >= 2:
        out['delivery_skew'] = spread(out['delivery'].values())
    return out


def summarize(args, rounds, failures, clocks, extra, same_sensor=True):
    """The JSON object of the run: ``extra`` merged into the figures of
    ``rounds`` (``analyse_round`` dicts).  ``args``: clients, rounds, dur,
    rate; ``same_sensor`` as for ``analyse_round``."""
    skews = [r['skew'] for r in rounds if 'skew' in r]
    errors = [abs(e) for r in rounds for e in r.get('errors', {}).values()]
    signed = {c: [r['errors'][c] for r in rounds
                  if c in r.get('errors', {})] for c in clocks}
    delays = {c: [d for r in rounds for d in r.get('delays', {}).get(c, [])]
              for c in clocks}
    all_delays = [d for v in delays.values() for d in v]
    return dict({
        'clients': args.clients,
        'rounds': args.rounds,
        'rounds_run': len(rounds),
        'ok': not failures,
        'start_skew_ms': ms(percentiles(skews)),
        'offset_error_ms': ms(percentiles(errors)),
        'clock_skew_ms': ms(percentiles(
            [r['model_skew'] for r in rounds if 'model_skew' in r])),
        'clock_model_error_ms': ms(percentiles(
            [abs(e) for r in rounds
             for e in r.get('model_errors', {}).values()])),
        'sample_delay_ms': ms(dict(percentiles(all_delays),
                                   min=min(all_delays, default=math.nan))),
        'sample_delay_p50_ms': {c: ms({'p50': median(v)})['p50']
                                if v else None
                                for c, v in sorted(delays.items())},
        'delivery_skew_ms': ms(percentiles(
            [r['delivery_skew'] for r in rounds if 'delivery_skew' in r])),
        'ack_round_ms': ms(percentiles(
            [r['ack_round'] for r in rounds if 'ack_round' in r])),
        'capture_order_ms': ms(percentiles(
            [r['capture_order'] for r in rounds if 'capture_order' in r])),
        'wake_lateness_ms': ms(percentiles(
            [w for r in rounds for w in r.get('wake', [])])),
        'ack_offset_error_ms': ms(percentiles(
            [e for r in rounds for e in r.get('ack_offset_error', [])])),
        'frames_per_window': {
            'expected': int(round(args.dur * args.rate)),
            'min': min((f for r in rounds for f in r.get('frames', [])),
                       default=None),
            'p50': median([f for r in rounds for f in r.get('frames', [])])},
        'str_aft_s': sorted({round(r['str_aft'], 3) for r in rounds
                             if 'str_aft' in r}),
        'rounds_measured': len(skews),
        'rounds_same_first_sample': sum(
            1 for r in rounds if r.get('same_first')) if same_sensor
        else None,
        'start_skew_per_round_ms': [round(r['skew'] * 1e3, 3)
                                    if 'skew' in r else None
                                    for r in rounds],
        'clock_model_errors_per_round_us': [
            {c: round(e * 1e6, 1) for c, e in sorted(
                r.get('model_errors', {}).items())} for r in rounds],
        'clock_error_mean_ms': {c: mean_ms(v)
                                for c, v in sorted(signed.items())},
        'clocks': {c: {'offset_s': round(k.offset, 6),
                       'drift_ppm': round(k.drift_ppm, 3),
                       'ack_offset_error_mean_ms': mean_ms(
                           [r['ack_offset_signed'][c] for r in rounds
                            if c in r.get('ack_offset_signed', {})])}
                   for c, k in sorted(clocks.items())},
        'failures': len(failures),
        'failure_counts': dict(Counter(k for k, _ in failures)),
        'failure_notes': [note for _, note in failures[:50]],
    }, **extra)
