#!/usr/bin/env python3
"""Write the device clock map's test vectors (test/data/clock_map/).

One stream of (device stamp, arrival, true capture time) per case, 30 Hz,
seeded, and ``cases.csv`` with each case's error bounds.  Both
test/unit/test_clock_map_vectors.py (Python's DeviceClockMapper) and the
gtest DeviceClock.SharedVectorsMeetPythonsBounds (the C++ tracker's)
replay every stream and hold the map to those bounds; the ``mapped`` column
is the Python map's ``to_global(device)`` right after observing the row
(empty while it is not ready), so the C++ is also checked to compute the
same map.  Re-run after changing the algorithm:

    scripts/make_clock_map_vectors.py
"""
import argparse
import math
import os
import random
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, 'src'))

from hri_sync.data_process.mapping import DeviceClockMapper  # noqa: E402

T0 = 1.7e9     # true time of the first frame (an epoch-sized clock)
RATE = 30.0    # frames per second (a Kinect)


def stream(rng, ppm, offset, dur, delay, t0=T0):
    """Rows (device, arrival, true) of a sensor whose clock reads
    ``offset`` at true time ``t0``; ``delay(rng)`` is a frame's delay."""
    out = []
    for k in range(int(dur * RATE)):
        true = t0 + k / RATE
        device = offset + (true - t0) * (1.0 + ppm)
        out.append((device, true + delay(rng), true))
    return out


def uniform(lo, hi):
    return lambda rng: rng.uniform(lo, hi)


def steady():
    return stream(random.Random(1), 0.0, 1234.5, 30.0,
                  uniform(0.3e-3, 15e-3))


def drifting():
    return stream(random.Random(2), -100e-6, 1234.5, 45.0,
                  uniform(0.3e-3, 15e-3))


def reader_stall():
    rows = []
    for device, arrival, true in stream(random.Random(3), 80e-6, 50.0, 20.0,
                                        uniform(0.3e-3, 15e-3)):
        if 3.0 <= true - T0 < 4.8:
            continue                          # lost while the reader stalled
        if abs(true - T0 - 2.97) < 0.02:
            arrival = T0 + 4.8                # held through the stall
        rows.append((device, arrival, true))
    return rows


def clock_reset():
    rng = random.Random(4)
    return (stream(rng, 0.0, 100.0, 10.0, uniform(0.3e-3, 15e-3))
            + stream(rng, 0.0, 0.0, 15.0, uniform(0.3e-3, 15e-3),
                     t0=T0 + 10.5))


def jitter():
    def delay(rng):
        d = 2e-3 + min(rng.expovariate(1 / 8e-3), 40e-3)
        return d + (0.2 if rng.random() < 0.1 else 0.0)
    return stream(random.Random(5), 150e-6, 12.5, 40.0, delay)


# generator, description, bound_ms (worst |map - true| once the fit spans
# skip_s), skip_s, settle_bound_ms (every ready row), resets.
CASES = [
    (steady, 'no drift, delays 0.3-15 ms', 1.5, 5.0, 16.0, 0),
    (drifting, 'device 100 ppm slow, delays 0.3-15 ms, 45 s (the 30 s '
     'window slides)', 1.5, 5.0, 16.0, 0),
    (reader_stall, 'test_capture.py\'s reader stall: 80 ppm, the reader '
     'stalls 1.8 s at 3 s and its held frame arrives 1.8 s late', 2.0, 5.0,
     16.0, 0),
    (clock_reset, 'the device restarts from 0 after 10 s (no drift, '
     'delays 0.3-15 ms)', 1.5, 5.0, 16.0, 1),
    (jitter, 'device 150 ppm fast, delays 2 ms + exponential (mean 8 ms, '
     'cut at 40 ms), 10 % of frames 200 ms later still', 3.0, 5.0, 45.0, 0),
]


def write_case(path, rows):
    """Round the inputs to 1 us (as both tests read them), map them with
    Python's DeviceClockMapper and write the CSV."""
    m = DeviceClockMapper()
    with open(path, 'w') as f:
        f.write('device,arrival,true,mapped\n')
        for device, arrival, true in rows:
            device, arrival, true = (float('%.6f' % v)
                                     for v in (device, arrival, true))
            m.observe(device, arrival)
            mapped = '%.7f' % m.to_global(device) if m.ready else ''
            f.write('%.6f,%.6f,%.6f,%s\n' % (device, arrival, true, mapped))
    return m


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--out', default=os.path.join(ROOT, 'test', 'data',
                                                  'clock_map'))
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, 'cases.csv'), 'w') as f:
        f.write('name,bound_ms,skip_s,settle_bound_ms,resets,description\n')
        for gen, desc, bound, skip, settle, resets in CASES:
            name = gen.__name__
            m = write_case(os.path.join(args.out, name + '.csv'), gen())
            assert m.resets == resets and math.isfinite(m.offset), name
            f.write('%s,%g,%g,%g,%d,"%s"\n'
                    % (name, bound, skip, settle, resets, desc))
            print('%s: %s' % (name, desc))


if __name__ == '__main__':
    main()
