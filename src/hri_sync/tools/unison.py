"""Several robots in unison: how far apart they start and how well their
headings agree over a dance.

No ROS.  Used by ``bench/robots_unison.py`` and the ``robots_unison``
rostests: each robot reports the true time (a raw CLOCK_REALTIME read,
past its libfaketime clock) of its first dance command in its
``ActionStart``, and its odometry's poses are put on the global clock by
its own clock model (global = true time where the time server serves
the host's clock).
"""
import bisect
import math

from hri_sync.robot.geometry import wrap_angle
from hri_sync.clock.skew import percentiles


def start_skews(starts, robots):
    """Per round, the spread (max - min, s) of the robots' true start
    times: ``starts`` maps round -> {robot: true time}.  Returns
    (skews {round: s}, missing {round: [robots without a start]}); a
    round some robot did not start has no skew."""
    skews, missing = {}, {}
    for round_id, by_robot in sorted(starts.items()):
        absent = [r for r in robots if not math.isfinite(
            by_robot.get(r, math.nan))]
        if absent:
            missing[round_id] = absent
            continue
        times = [by_robot[r] for r in robots]
        skews[round_id] = max(times) - min(times)
    return skews, missing


def heading_at(track, t):
    """The heading (rad) of ``track`` (sorted (time, heading) pairs) at
    time ``t``, interpolated along the shorter way; None outside it."""
    times = [p[0] for p in track]
    i = bisect.bisect_left(times, t)
    if i < len(track) and times[i] == t:
        return track[i][1]
    if i == 0 or i == len(track):
        return None
    (t0, h0), (t1, h1) = track[i - 1], track[i]
    return h0 + wrap_angle(h1 - h0) * (t - t0) / (t1 - t0)


def spread(headings):
    """The largest wrapped difference (rad, >= 0) between any two of
    ``headings``."""
    return max((abs(wrap_angle(a - b)) for i, a in enumerate(headings)
                for b in headings[i + 1:]), default=0.0)


def heading_spreads(tracks, start, end, step=0.02):
    """The spread of the robots' headings (rad) every ``step`` s from
    ``start`` to ``end``: ``tracks`` maps robot -> sorted (global time,
    heading) pairs.  Instants where some robot has no pose on both sides
    are left out."""
    out = []
    n = int(math.floor((end - start) / step + 1e-9))
    for k in range(n + 1):
        t = start + k * step
        headings = [heading_at(track, t) for track in tracks.values()]
        if None not in headings:
            out.append(spread(headings))
    return out


def distribution(values, scale=1.0, unit='ms'):
    """{'n', 'p50_<unit>', 'p99_<unit>', 'max_<unit>'} of ``values``
    times ``scale`` (NaN: none)."""
    p = percentiles([v * scale for v in values])
    return {'n': len([v for v in values if math.isfinite(v)]),
            'p50_' + unit: p['p50'], 'p99_' + unit: p['p99'],
            'max_' + unit: p['max']}
