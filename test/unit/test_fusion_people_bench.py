"""hri_sync_support.fusion_people: the walkers of the fusion bench's
``--people`` and the scoring of fused ids against the truth."""
import math
import os
import sys

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, 'support'))

from hri_sync.dance_off.joints import INDEX, NUM_JOINTS  # noqa: E402
from hri_sync.dance_off.motion import Motion  # noqa: E402
from hri_sync_support.fusion_people import (  # noqa: E402
    AWAY, gait_cycle, present, score, walker)


def body(x, y=0.0):
    p = np.zeros((NUM_JOINTS, 3))
    p[:, 2] = np.linspace(1.6, 0.05, NUM_JOINTS)
    p[:, 0], p[:, 1] = x, y
    return p


def test_a_walker_crosses_straight_at_its_speed_then_is_away():
    # A synthetic walk: hips on at 1.2 m/s along +x, legs swinging with
    # a 1 s period (the cycle the search must find).
    t = np.arange(0, 8, 1 / 60)
    pos = np.array([body(1.2 * s) for s in t])
    for j in ('left_foot', 'right_foot'):
        pos[:, INDEX[j], 0] += 0.3 * np.sin(2 * math.pi * t) \
            * (1 if j == 'left_foot' else -1)
    walk = Motion(t, pos)
    start, period, d = gait_cycle(walk, starts=(1.0, 1.5))
    assert abs(period - 1.0) < 0.02
    assert np.allclose(d, [1.2 * period, 0, 0], atol=0.02)
    heading = math.radians(90)
    w = walker(walk, (start, period, d), [(1.0, (2.0, 0.0), heading, 6.0)],
               8.0)
    torso = w.positions[:, INDEX['torso']]
    on = present(w.positions)
    assert not on[w.times < 1.0].any() and not on[w.times > 6.1].any()
    assert (torso[~on, 2] < AWAY / 2).all()
    walking = torso[on]
    assert np.allclose(walking[:, 0], 2.0, atol=0.05)
    assert walking[0, 1] < -2.9 and walking[-1, 1] > 2.9
    speed = np.diff(walking[:, 1]) * 60
    assert abs(np.median(speed) - 1.2) < 0.05


def test_switches_reentries_transfers_duplicates_and_missing():
    # Two people 2 m apart for 3 s at 10 Hz. Person 0 is fused as id 1,
    # then id 3 (a switch), person 1 as id 2; a fused body where nobody
    # stands at 1.0 s (a duplicate); person 1 unfused at 2.0 s while a
    # view sees them (missing), unseen from 2.1 s to 2.5 s, then fused as
    # id 4 (a switch: unseen for less than LEFT) and as id 1 from 2.8 s
    # (a switch, and a transfer of id 1 from person 0). Unseen from 1.2 s
    # instead, the change to id 4 is a re-entry.
    times = np.arange(30) / 10

    def truth(t):
        return np.array([body(0.0), body(2.0)])

    def seen(t):
        return np.array([True, not 2.1 <= t < 2.5])

    instants = []
    for t in times:
        fused = [(1 if t < 1.5 else 3, body(0.05))]
        if t < 2.0:
            fused.append((2, body(2.0)))
        elif t >= 2.5:
            fused.append((4 if t < 2.8 else 1, body(2.0)))
        if t == 1.0:
            fused.append((9, body(5.0)))
        instants.append((t, fused))
    out = score(instants, truth, seen)
    assert out['id_switch_at'] == [(1.5, 0, 1, 3), (2.5, 1, 2, 4),
                                   (2.8, 1, 4, 1)]
    assert out['id_switches'] == 3
    assert out['reentries'] == 0             # unseen 0.4 s only
    assert out['id_transfers'] == 1
    assert out['duplicate_instants'] == 1
    assert out['duplicate_people'] == 1
    assert out['missing_people'] == 1
    assert out['fused_mean_m'] == [0.05, 0.0]
    long_gap = score(instants, truth,
                     lambda t: np.array([True, not 1.2 <= t < 2.5]))
    assert long_gap['reentries'] == 1 and long_gap['id_switches'] == 2
