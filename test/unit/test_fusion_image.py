"""hri_sync.fusion: a view's joints that the fused body has outside the
view's image (``sightlines.outside_image``) are left out and counted; the
views that see them give them."""
import math
from dataclasses import replace

import numpy as np

from hri_sync.dance_off.joints import INDEX
from hri_sync.fusion.frames import facing
from hri_sync.fusion.pipeline import FusionParams
from hri_sync.fusion.report import view_status
from hri_sync.fusion.sightlines import SightParams, outside_image
from test_fusion_core import body
from test_fusion_wrong_pose import run as feed

FEET = [INDEX['left_foot'], INDEX['right_foot']]
POSES = {'near': facing(1.3, 0.0, 1.0),     # the feet below its image
         'side': facing(0.0, 3.0, 1.0)}


def test_outside_image_by_field_and_margin():
    person = body()
    assert not outside_image(facing(3.0, 0.0, 1.0), person,
                             SightParams()).any()
    near = outside_image(facing(1.3, 0.0, 1.0), person, SightParams())
    # 1.3 m away, 1 m up: 21.5 + 5 degrees reach 0.35-1.65 m high
    assert set(np.flatnonzero(near)) == {INDEX['left_foot'],
                                         INDEX['right_foot']}
    assert not outside_image(facing(1.3, 0.0, 1.0), person,
                             SightParams(beyond_deg=25.0)).any()
    assert outside_image(facing(1.3, 0.0, 1.0), person,
                         SightParams(vertical_fov_deg=20.0)).sum() > 2
    turned = facing(0.0, 3.0, 1.0, target=(10.0, 3.0))     # looks away
    assert outside_image(turned, person, SightParams()).all()
    sideways = facing(0.0, 3.0, 1.0, target=(3.0, 0.0))    # 45 deg off
    assert outside_image(sideways, person, SightParams()).all()
    assert not outside_image(sideways, person,
                             SightParams(fov_deg=120.0)).any()
    hidden = person.copy()
    hidden[INDEX['head']] = np.nan
    assert not outside_image(facing(1.3, 0.0, 1.0), hidden,
                             SightParams())[INDEX['head']]


def fused_feet(params):
    """The fusion and its feet's mean error over 2 s of a still person:
    'near' (1.3 m away) gives its feet 0.4 m off, as a tracker guessing
    what is below its image; 'side' sees them right."""
    truth = body()

    def seen(view, t):
        out = truth.copy()
        if view == 'near':
            out[FEET] += [0.0, 0.4, 0.0]
        return out
    fusion, frames = feed(2.0, {}, [seen], poses=POSES, params=params)
    feet = np.array([f.people[0].body.positions[FEET] for f in frames[-15:]])
    return fusion, float(np.linalg.norm(feet - truth[FEET], axis=-1).mean())


def test_joints_outside_a_views_image_are_left_out_and_counted():
    fusion, error = fused_feet(FusionParams())
    blind = FusionParams()
    blind.sight = replace(blind.sight, beyond_deg=math.inf)
    plain, before = fused_feet(blind)
    assert error < 0.03 < before
    assert fusion.health['near'].out_of_image > 0
    assert fusion.health['side'].out_of_image == 0
    assert plain.health['near'].out_of_image == 0
    _, _, _, values = view_status(fusion, 'near')
    assert ('joints out of image',
            str(fusion.health['near'].out_of_image)) in values
