"""hri_sync.fusion: a view's skeleton of someone farther than its sensor
tracks (``sight.far``) is taken to err more than its profile's sigma, up
to ``far_sigma`` times at its depth range (``sight.range``) and beyond,
and counted; one within range is fused as before."""
import math

import numpy as np

from hri_sync.dance_off.joints import INDEX
from hri_sync.fusion.frames import SensorPose
from hri_sync.fusion.pipeline import FusionParams
from hri_sync.fusion.report import view_status
from hri_sync.fusion.sightlines import SightParams
from test_fusion_core import body
from test_fusion_wrong_pose import run as feed

POSES = {'near': SensorPose(3.0, 0.0, 1.0, math.pi),
         'side': SensorPose(0.0, 3.0, 1.0, -math.pi / 2),
         'far': SensorPose(-5.5, 0.0, 1.0, 0.0)}


def fused(far_sigma, person=(0.0, 0.0), depth_range=5.0):
    """The fused head over 2 s of three views of one still person at
    ``person``: 'near' and 'side' see them right, 'far' (5.5 m from the
    origin) 0.2 m off."""
    truth = body(*person)

    def seen(view, t):
        return truth + ([0.0, 0.2, 0.0] if view == 'far' else 0.0)
    fusion, frames = feed(2.0, {}, [seen], poses=POSES,
                          params=FusionParams(far_sigma=far_sigma,
                                              sight=SightParams(
                                                  range=depth_range)))
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


def test_between_tracking_and_depth_range_the_weight_falls_gradually():
    person = (-0.75, 0.0)                          # 4.75 m from 'far'
    _, plain = fused(1.0, person)
    half, halfway = fused(3.0, person)
    _, cut = fused(3.0, person, depth_range=4.75)
    assert plain > halfway > cut
    assert half.health['far'].beyond_range > 0
