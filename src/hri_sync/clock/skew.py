"""Ground-truth timing analysis of a round: clock errors and start skew.

No ROS.  Used by the demo's round monitor, the rostests and the benchmark.
A reference sensor on the true clock writes each sample's true time into
the sample; a client stamps the sample in its global time at arrival.  So
``global stamp - true time`` is the client's clock error plus the transport
delay; the minimum over the first samples of the window removes most of
the delay, as NTP does with its minimum-delay sample.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any


@dataclass
class ClientTiming:
    """One client's kept samples of one round."""

    client_id: str
    first_index: int        # the sensor's index of the first kept sample
    clock_error: float      # global stamp minus true time, s (start or end)
    samples: int


def client_timing(client_id: str, kept: list[Any], head: int = 10,
                  at_end: bool = False) -> ClientTiming:
    """Timing of one client from ``kept``: (global_stamp, true_time, index)
    tuples of the samples it kept, in any order.  The clock error is taken
    over the first ``head`` samples, or the last ones with ``at_end``."""
    if not kept:
        return ClientTiming(client_id, -1, math.nan, 0)
    kept = sorted(kept, key=lambda k: k[1])
    edge = kept[-head:] if at_end else kept[:head]
    error = min(g - t for g, t, _ in edge)
    return ClientTiming(client_id, kept[0][2], error, len(kept))


def start_skew(timings: list[Any]) -> float:
    """Spread (max - min) of the clients' clock errors at the window start,
    in s; NaN with fewer than two clients that kept samples."""
    errors = [t.clock_error for t in timings if math.isfinite(t.clock_error)]
    if len(errors) < 2:
        return math.nan
    return max(errors) - min(errors)


def percentiles(values: list[float],
                qs: tuple[int, int] = (50, 99)) -> dict[str, float]:
    """Nearest-rank percentiles of ``values`` as {'pNN': v, ..., 'max': v}."""
    vals = sorted(v for v in values if math.isfinite(v))
    out = {}
    for q in qs:
        if vals:
            k = max(0, min(len(vals) - 1, math.ceil(q / 100 * len(vals)) - 1))
            out['p%d' % q] = vals[k]
        else:
            out['p%d' % q] = math.nan
    out['max'] = vals[-1] if vals else math.nan
    return out
