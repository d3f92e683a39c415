"""hri_sync.fusion: a view's skeleton of someone farther than its sensor
tracks (``sight.far``) is taken to err ``far_sigma`` times its profile's
sigma, and counted; one within range is fused as before."""
import math

import numpy as np

from hri_sync.dance_off.joints import INDEX, NUM_JOINTS
from hri_sync.fusion.frames import SensorPose
from hri_sync.fusion.pipeline import Fusion, FusionParams
from hri_sync.fusion.report import view_status


def standing(x, y):
    """A still body in world at (x, y): joints at its height, 0.2 m wide."""
    p = np.zeros((NUM_JOINTS, 3))
    for j in range(NUM_JOINTS):
        p[j] = (x, y + (0.2 if j % 2 else -0.2), 1.6 - 0.1 * j)
    return p


def fused(far_sigma, person=(0.0, 0.0)):
    """The fused head over 2 s of three views of one still person at
    ``person``: 'near' and 'side' see them right, 'far' (5.5 m from the
    origin) 0.2 m off."""
    poses = {'near': SensorPose(3.0, 0.0, 1.0, math.pi),
             'side': SensorPose(0.0, 3.0, 1.0, -math.pi / 2),
             'far': SensorPose(-5.5, 0.0, 1.0, 0.0)}
    clock = {'now': 0.0}
    fusion = Fusion(poses, FusionParams(far_sigma=far_sigma),
                    clock=lambda: clock['now'])
    truth = standing(*person)
    frames = []
    for k in range(60):
        t = k / 30.0
        clock['now'] = t + 0.05
        for view, pose in poses.items():
            world = truth + ([0.0, 0.2, 0.0] if view == 'far' else 0.0)
            fusion.add(view, 1, t, pose.from_world(world),
                       np.full(NUM_JOINTS, 0.9), 0.001)
        frames += fusion.poll()
    head = frames[-1].people[0].body.positions[INDEX['head']]
    return fusion, float(np.linalg.norm(head - truth[INDEX['head']]))


def test_a_view_beyond_its_range_weighs_less_and_is_counted():
    fusion, error = fused(3.0)
    _, plain = fused(1.0)
    assert error < plain / 2
    assert fusion.health['far'].beyond_range > 0
    assert fusion.health['near'].beyond_range == 0
    _, _, _, values = view_status(fusion, 'far')
    assert ('beyond range', str(fusion.health['far'].beyond_range)) in values


def test_within_range_nothing_changes():
    near, error = fused(3.0, person=(-1.2, 0.0))   # 4.3 m from 'far'
    _, plain = fused(1.0, person=(-1.2, 0.0))
    assert near.health['far'].beyond_range == 0
    assert error == plain
