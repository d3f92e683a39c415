"""Plain-text round reports (no ROS): offsets, clock errors, start skew."""
import math

from hri_sync.wire.protocol import Capture
from hri_sync.clock.skew import client_timing, start_skew


def _ms(x, signed=True):
    if x is None or not math.isfinite(x):
        return '-'
    return ('%+.3f' if signed else '%.3f') % (x * 1e3)


def round_report(n, acks, capture, results, captured, decision):
    """Text table of one round.

    ``acks``/``results``: {client: message}; ``captured``: {client:
    [(global stamp, true time, id)]}; ``capture``/``decision``: messages or
    None.  Returns (text, timings) where timings are skew.ClientTiming.
    """
    clients = list(capture.clients) if capture else sorted(acks)
    lines = ['round %d' % n]
    if capture:
        c = Capture(n, capture.header.stamp.to_sec(), capture.str_aft,
                    capture.dur, clients)
        lines.append('  window: CR_T %.6f + STR_AFT %.3f s, DUR %.3f s '
                     '(global start %.6f)' % (c.cr_t, c.str_aft, c.dur,
                                              c.start))
    lines.append('  %-10s %-4s %14s %9s %13s %11s %7s %-8s %s' % (
        'client', 'ack', 'offset [s]', 'unc [ms]', 'clk err [ms]',
        'wake [ms]', 'frames', 'status', 'value'))
    timings = []
    for c in sorted(set(clients) | set(acks)):
        a, r = acks.get(c), results.get(c)
        t = client_timing(c, captured.get(c, []))
        timings.append(t)
        lines.append('  %-10s %-4s %14s %9s %13s %11s %7s %-8s %s' % (
            c, ('ok' if a.ok else 'NACK') if a else '-',
            '%+.6f' % a.offset if a and math.isfinite(a.offset) else '-',
            _ms(a.uncertainty, False) if a else '-',
            _ms(t.clock_error), _ms(r.wake_lateness) if r else '-',
            r.frames if r else '-', r.status if r else '-',
            '%.6g' % r.value if r else '-'))
        if a and not a.ok:
            lines.append('      NACK reason: %s' % a.reason)
    skew = start_skew(timings)
    if math.isfinite(skew):
        lines.append('  start skew across clients (true time): %.3f ms'
                     % (skew * 1e3))
    if decision:
        who = ''
        if decision.winner:
            listed = 0 < decision.winner <= len(decision.clients)
            who = ' participant %d (%s)' % (
                decision.winner, decision.clients[decision.winner - 1]
                if listed else 'not in its client list %s'
                % list(decision.clients))
        lines.append('  decision: %s%s: %s' % (decision.outcome, who,
                                               decision.reason))
    else:
        lines.append('  decision: none received')
    return '\n'.join(lines), timings


def frames_brought(samples):
    """How many frames the captured ``samples`` [(global stamp, ...)]
    hold: their distinct stamps (a tracker's frame with a bystander in
    view is two skeletons of one stamp; a result counts frames)."""
    return len({s[0] for s in samples})
