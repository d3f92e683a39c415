"""hri_sync.tools.analysis.build_up: the report's cumulative score."""

from types import SimpleNamespace as NS

import numpy as np
import pytest

from hri_sync.dance_off.expressiveness import expressiveness
from hri_sync.dance_off.joints import NUM_JOINTS
from hri_sync.tools.analysis import build_up


def frames_of(stamps, pos, conf):
    """[(stamp, Skeleton-like)] as a recording is read back."""
    return [(float(s), NS(positions=[NS(x=x, y=y, z=z) for x, y, z in p],
                          confidence=list(c)))
            for s, p, c in zip(stamps, pos, conf)]


def per_prefix(stamps, pos, conf, start, dur, points, min_confidence):
    """The definition: each point scores the frames stamped up to it."""
    out = []
    for t in np.linspace(0.0, dur, points + 1)[1:]:
        k = stamps <= start + t
        out.append(expressiveness(stamps[k], pos[k], conf[k], duration=dur,
                                  min_confidence=min_confidence).value
                   if k.any() else 0.0)
    return out


@pytest.mark.parametrize('seed', [1, 2, 3])
def test_one_pass_equals_scoring_each_prefix(seed):
    rng = np.random.default_rng(seed)
    n, start, dur = 400, 100.0, 4.0
    stamps = start + np.sort(rng.uniform(-0.2, dur + 0.2, n))
    stamps[50] = stamps[49]                     # a repeated stamp
    pos = rng.normal(0.0, 0.3, (n, NUM_JOINTS, 3)).cumsum(axis=0) * 0.05
    pos[rng.random((n, NUM_JOINTS)) < 0.02] = np.nan       # NaN joints
    conf = rng.uniform(0.2, 1.0, (n, NUM_JOINTS))
    pos[120:125] = pos[119]                     # frames that repeat a pose
    shuffled = rng.permutation(n)               # recorded out of order
    stamps, pos, conf = stamps[shuffled], pos[shuffled], conf[shuffled]
    got = build_up(frames_of(stamps, pos, conf), start, dur, 0.5, points=37)
    want = per_prefix(stamps, pos, conf, start, dur, 37, 0.5)
    assert got['t'] == pytest.approx(np.linspace(0, dur, 38)[1:].tolist())
    assert got['value'] == pytest.approx(want, rel=1e-12, abs=1e-15)
    assert got['value'][0] > 0 and got['value'][-1] > got['value'][0]


def test_no_frames_and_frames_after_the_window():
    assert build_up([], 0.0, 1.0, 0.5) == {'t': [], 'value': []}
    pos = np.zeros((3, NUM_JOINTS, 3))
    late = frames_of(np.array([5.0, 5.1, 5.2]), pos, np.ones((3, NUM_JOINTS)))
    assert build_up(late, 0.0, 1.0, 0.5, points=4)['value'] == [0.0] * 4
