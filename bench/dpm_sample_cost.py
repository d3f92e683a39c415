#!/usr/bin/python3
"""CPU a skeleton DPM spends per sample, and what its parts cost (JSON).

    source <ws>/devel/setup.bash
    /usr/bin/python3 bench/dpm_sample_cost.py [--rate 100] [--seconds 120]

Feeds ``--seconds`` of seeded 15-joint skeletons at ``--rate`` Hz, as
serialized hri_sync/Skeleton messages, through what a DPM does with each
(genpy deserialization and ``DataProcess.on_sample``: device clock map,
quiet baseline, one capture window (60 s, from 10 s) of SkeletonExpressiveness), with
no ROS master, and reads its own CPU time (``time.process_time``) per
sample, ``--repeats`` times in each of three modes, interleaved:

- ``shipped``: as the DPM runs;
- ``full_quiet_stretches``: the quiet baseline's overlapping 1 s stretches
  scored as whole windows (``begin`` instead of ``begin_quiet``: each
  stretch also estimates a jitter floor nobody reads);
- ``no_baseline``: no quiet baseline at all (a processor without
  ``quiet_baseline``), the floor under both.

Prints per mode the median and max microseconds per sample and the share
of one core at ``--rate`` Hz, and the ratios of the medians to
``shipped``. All three give the same result; the bench checks it.
"""
import argparse
import io
import json
import statistics
import time

import numpy as np
import rospy
from geometry_msgs.msg import Point, Quaternion

from hri_sync.clock.model import ClockModel
from hri_sync.dance_off.expressiveness import SkeletonExpressiveness
from hri_sync.data_process.dpm import DataProcess
from hri_sync.msg import Skeleton

T0 = 1000.0


def messages(rate, seconds, seed=1):
    """[(stamp, serialized Skeleton)]: a still body with 2 cm jitter."""
    rng = np.random.default_rng(seed)
    body = rng.uniform(-0.5, 0.5, (15, 3)) + [0.0, 0.0, 2.5]
    out = []
    for k in range(int(rate * seconds)):
        t = T0 + k / rate
        m = Skeleton(client_id='c1', user_id=1)
        m.header.stamp = m.device_stamp = rospy.Time.from_sec(t)
        m.positions = [Point(*p) for p in body + rng.normal(0, 0.02,
                                                             (15, 3))]
        m.orientations = [Quaternion(w=1.0) for _ in range(15)]
        m.confidence = [0.9] * 15
        buf = io.BytesIO()
        m.serialize(buf)
        out.append((t, buf.getvalue()))
    return out


class FullStretches(SkeletonExpressiveness):
    """Quiet stretches scored as whole windows."""

    def begin_quiet(self, start, end):
        self.begin(start, end)


class NoBaseline(SkeletonExpressiveness):
    quiet_baseline = False


MODES = {'shipped': SkeletonExpressiveness,
         'full_quiet_stretches': FullStretches, 'no_baseline': NoBaseline}


def run(cls, msgs):
    """(CPU s per sample, the window's value) of one pass."""
    core = DataProcess(cls, stamp_source='device')
    core.set_clock(ClockModel(0.0, 0.0, 0.0, 1e-4))
    seconds = (msgs[-1][0] - T0)
    core.open(1, T0 + 10.0, T0 + 10.0 + min(60.0, seconds - 11.0))
    values = []
    start = time.process_time()
    for t, raw in msgs:
        step = core.on_sample(Skeleton().deserialize(raw), t + 0.002, raw)
        values += [r.value for r in step.results]
    return (time.process_time() - start) / len(msgs), values


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--rate', type=float, default=100.0)
    parser.add_argument('--seconds', type=float, default=120.0)
    parser.add_argument('--repeats', type=int, default=3)
    args = parser.parse_args()
    if args.seconds < 15.0:
        parser.error('--seconds must be >= 15 (the window starts at 10 s)')
    msgs = messages(args.rate, args.seconds)
    costs = {m: [] for m in MODES}
    values = {}
    for _ in range(args.repeats):
        for mode, cls in MODES.items():
            cost, values[mode] = run(cls, msgs)
            costs[mode].append(cost)
    if len({tuple(v) for v in values.values()}) != 1:
        raise SystemExit('the modes disagree: %s' % values)
    med = {m: statistics.median(c) for m, c in costs.items()}
    print(json.dumps({
        'rate_hz': args.rate, 'samples': len(msgs), 'repeats': args.repeats,
        'window_value': values['shipped'][0],
        'us_per_sample': {m: {'median': round(med[m] * 1e6, 1),
                              'max': round(max(c) * 1e6, 1)}
                          for m, c in costs.items()},
        'core_share_at_rate': {m: round(med[m] * args.rate, 4)
                               for m in MODES},
        'ratio_to_shipped': {m: round(med[m] / med['shipped'], 2)
                             for m in MODES}}, indent=1))


if __name__ == '__main__':
    main()
