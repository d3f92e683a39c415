#!/usr/bin/env python3
"""Noise floors of real Kinect skeleton streams and the noise rule's calls.

Prints JSON.  Each recording of ../shared/data/real_skeleton (--src) is fed
to the DPM's noise-floor measures as a client would see it (the quiet
baseline of 1 s stretches every 0.25 s over the whole recording, the
window's own jitter floor) and scored in --window s windows every 0.1 s.
Then every calm window is paired with every other calm window (the rule
must say ``no_winner``) and with every gesture window (the gesture must
win), for each --factors, and the calls are counted.  Calm windows: those
inside the still stretches of Kinect v2 ``joints.csv`` (CALM) and the
still starts of Kinect v1 sequences (the first second of those whose
first second scores under 0.1 on this sensor).  Gestures: every window of
the six Kinect v2 gesture captures; punches: every Kinect v1 window over
its sequence's median.  The sets marked ``check`` (Ges01_wavehand, the
``real_k2_calm`` stretch of joints.csv, Kinect v1 subjects 4-6) are left
out of ``choose`` and reported apart.

``--calibrate``: as a DPM after the CM's calibration window (nobody
moving), each stream's quiet level is a calibration score instead of its
own quietest second: for Kinect v2 the score of the ``real_k2_calm``
stretch of joints.csv (5.2-6.9 s, the recording the rostests replay as a
Kinect v2's calibration), for a Kinect v1 sequence the score of its own
first second (its person standing before the punches); a sequence whose
first second is not still (0.1 or more) has no calibration and is left
out.
"""
import argparse
import glob
import itertools
import json
import math
import os
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, 'src'))
sys.path.insert(0, os.path.join(ROOT, 'scripts'))

from hri_sync.dance_off.expressiveness import (  # noqa: E402
    RunningExpressiveness)
from hri_sync.people.kinect_csv import (read_kinect_v1,  # noqa: E402
                                        read_kinect_v2)
from hri_sync.decision.rule import NOISE, decide  # noqa: E402
from hri_sync.data_process.noise_floor import (QuietBaseline,  # noqa: E402
                                               combine)
from hri_sync.data_process.processors import (Processor,  # noqa: E402
                                              ProcessResult)
from convert_real_skeleton import DEFAULT_SRC  # noqa: E402

# Kinect v2 joints.csv: a person standing still between gestures, s
CALM = {'choose': [(1.4, 2.7)], 'check': [(5.2, 6.9)]}   # check: real_k2_calm
CHECK_FILES = ('Ges01_wavehand.csv',)
CHECK_V1_SUBJECTS = ('Seq4_', 'Seq5_', 'Seq6_')


class Arrays(Processor):
    """The skeleton score of frames given as (positions, confidence)."""

    quiet_baseline = True

    def begin(self, start, end):
        self._run = RunningExpressiveness(15)
        self._t = end - start

    def add(self, frame):
        self._run.add(frame.stamp, *frame.msg)

    def result(self):
        r = self._run.score(self._t)
        return ProcessResult(r.value, r.frames_used, noise_floor=r.jitter)


def score(rec, t0, t1):
    """(score, jitter floor) of a recording's [t0, t1)."""
    k = (rec.stamps >= t0) & (rec.stamps < t1)
    proc = Arrays()
    proc.begin(t0, t1)
    for t, p, c in zip(rec.stamps[k], rec.positions[k], rec.confidence[k]):
        proc.add(type('F', (), {'stamp': float(t), 'msg': (p, c)}))
    r = proc.result()
    return r.value, r.noise_floor


def windows(rec, width, step=0.1, calibration=None):
    """[(t0, score, jitter floor, quiet level, floor)] of a recording; the
    quiet level is ``calibration`` when given, else the quiet baseline."""
    base = QuietBaseline(Arrays)
    for t, p, c in zip(rec.stamps, rec.positions, rec.confidence):
        base.add(float(t), (p, c))
    base.add(float(rec.stamps[-1]) + 10.0, (rec.positions[-1],
                                            rec.confidence[-1]))
    quiet = base.level()[0] if calibration is None else calibration
    out = []
    for t0 in np.arange(0.0, rec.stamps[-1] - width + 1e-9, step):
        k = (rec.stamps >= t0) & (rec.stamps < t0 + width)
        proc = Arrays()
        proc.begin(t0, t0 + width)
        for t, p, c in zip(rec.stamps[k], rec.positions[k],
                           rec.confidence[k]):
            proc.add(type('F', (), {'stamp': float(t), 'msg': (p, c)}))
        r = proc.result()
        out.append((float(t0), r.value, r.noise_floor, quiet,
                    combine(r.noise_floor, quiet)))
    return out


def inside(t0, width, spans):
    return any(a <= t0 and t0 + width <= b for a, b in spans)


def collect(src, width, calibrate=False):
    sets = {k: {'calm': [], 'move': []} for k in ('choose', 'check')}
    levels = {}
    k2 = None
    if calibrate:
        k2 = score(read_kinect_v2(os.path.join(src, 'kinect2_laban',
                                               'joints.csv')),
                   *CALM['check'][0])[0]
        levels['calibration (real_k2_calm)'] = round(k2, 4)
    for path in sorted(glob.glob(os.path.join(src, 'kinect2_laban/*.csv'))):
        name = os.path.basename(path)
        w = windows(read_kinect_v2(path), width, calibration=k2)
        levels[name] = summary(w)
        if name == 'joints.csv':
            for part, spans in CALM.items():
                sets[part]['calm'] += [x for x in w
                                       if inside(x[0], width, spans)]
        else:
            part = 'check' if name in CHECK_FILES else 'choose'
            sets[part]['move'] += w
    v1_calm, v1_move = {'choose': [], 'check': []}, {'choose': [],
                                                     'check': []}
    for path in sorted(glob.glob(os.path.join(src, 'kinect1_precog/*.csv'))):
        name = os.path.basename(path)
        rec = read_kinect_v1(path)
        first = score(rec, 0.0, 1.0)[0]
        if rec.stamps[-1] < 2 * width or calibrate and not first < 0.1:
            continue
        w = windows(rec, width, calibration=first if calibrate else None)
        part = 'check' if name.startswith(CHECK_V1_SUBJECTS) else 'choose'
        if w[0][1] < 0.1:
            v1_calm[part].append(w[0])
        med = np.median([x[1] for x in w])
        v1_move[part] += [x for x in w if x[1] >= med]
    return sets, levels, v1_calm, v1_move


def summary(w):
    a = np.array([x[1:] for x in w])
    if not len(a):
        return {}
    return {k: [round(float(np.min(a[:, i])), 4),
                round(float(np.median(a[:, i])), 4),
                round(float(np.max(a[:, i])), 4)]
            for i, k in enumerate(('score', 'jitter', 'quiet', 'floor'))}


def calls(calm, move, factor):
    """(calm pairs with no_winner, of; gesture wins, of)."""
    def verdict(a, b):
        return decide(['a', 'b'], {'a': ('ok', a[1], a[4]),
                                    'b': ('ok', b[1], b[4])},
                      rule=NOISE, noise_factor=factor)
    still = [verdict(a, b).outcome == 'no_winner'
             for a, b in itertools.combinations(calm, 2)]
    wins = [verdict(m, c).winner == 1 for m in move for c in calm]
    return {'calm_vs_calm_no_winner': '%d/%d' % (sum(still), len(still)),
            'gesture_vs_calm_gesture_wins': '%d/%d' % (sum(wins), len(wins))}


def main():
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--src', default=DEFAULT_SRC)
    parser.add_argument('--window', type=float, default=1.0)
    parser.add_argument('--factors', default='1.5,2,3,4,5')
    parser.add_argument('--calibrate', action='store_true',
                        help='quiet levels from a calibration (see above)')
    args = parser.parse_args()
    sets, levels, v1_calm, v1_move = collect(args.src, args.window,
                                             args.calibrate)
    out = {'window_s': args.window, 'calibrated': args.calibrate,
           'kinect_v2_levels [min, median, max]': levels}
    for part in ('choose', 'check'):
        s = sets[part]
        out[part] = {'kinect_v2_calm_windows': len(s['calm']),
                     'kinect_v2_calm': summary(s['calm']),
                     'kinect_v2_gesture_windows': len(s['move']),
                     'kinect_v1_still_starts': summary(v1_calm[part]),
                     'kinect_v1_punch_windows': len(v1_move[part])}
        for f in (float(x) for x in args.factors.split(',')):
            out[part]['factor %g' % f] = {
                'kinect_v2': calls(s['calm'], s['move'], f),
                'kinect_v1': calls(v1_calm[part], v1_move[part], f)}
    print(json.dumps(out, indent=1))


if __name__ == '__main__':
    main()
