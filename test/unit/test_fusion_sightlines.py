"""hri_sync.fusion.sightlines: two views that never give one person though
each one's people stand in the other's sight are reported (a pose wrong by
more than the gates, with no third view to say which); people hidden or out
of a view's field are not."""
import math
import re

import numpy as np

from hri_sync.fusion.frames import SensorPose, facing
from hri_sync.fusion.report import view_status
from hri_sync.fusion.sightlines import SightParams, Sightlines, in_sight
from test_fusion_wrong_pose import run as feed

FRONT = facing(3.0, 0.0, 1.0)
SIDE = facing(0.0, -3.0, 1.0)
POSES = {'front': FRONT, 'side': SIDE}


def body_at(x, y):
    """A still standing body (world joints, 15 x 3) at (x, y)."""
    rng = np.random.default_rng(int(1000 * (x + 7 * y)) % 2**32)
    heights = np.linspace(0.1, 1.7, 15)
    return np.column_stack([x + rng.uniform(-0.2, 0.2, 15),
                            y + rng.uniform(-0.2, 0.2, 15), heights])


def run(seconds, seen, actual=None):
    """A Fusion of POSES fed ``seen`` {view: [world body of each user]},
    a view in ``actual`` {view: pose} placing its bodies by that pose
    (test_fusion_wrong_pose.run). Returns the fusion and its frames."""
    bodies = list({id(b): b for bs in seen.values() for b in bs}.values())
    people = [lambda v, t, b=b: b if any(b is x for x in seen.get(v, ()))
              else None for b in bodies]
    return feed(seconds, actual or {}, people, poses=POSES)


def unmatched(fusion):
    return {v: [d for f, d in faults if f == 'unmatched']
            for v, faults in fusion.faults().items()}


def test_in_sight_field_range_and_shadow():
    p = SightParams()
    assert in_sight(FRONT, np.array([0.0, 0.0]), [], p)
    assert not in_sight(FRONT, np.array([0.0, 2.5]), [], p)   # 40 deg off
    assert not in_sight(FRONT, np.array([-2.0, 0.0]), [], p)  # 5 m away
    assert not in_sight(FRONT, np.array([2.6, 0.0]), [], p)   # too near
    # someone in front, on the line of sight, hides; beside it does not
    assert not in_sight(FRONT, np.array([0.0, 0.0]),
                        [np.array([1.5, 0.1])], p)
    assert in_sight(FRONT, np.array([0.0, 0.0]), [np.array([1.5, 0.8])], p)
    assert in_sight(FRONT, np.array([0.0, 0.0]),
                    [np.array([-1.0, 0.0])], p)   # behind them


def test_a_still_person_twice_from_a_misplaced_view_is_reported():
    person = body_at(0.0, 0.0)
    wrong = SensorPose(SIDE.x + 1.2, SIDE.y, SIDE.z, SIDE.yaw)  # 1.2 m off
    fusion, frames = run(5.0, {'front': [person], 'side': [person]},
                         actual={'side': wrong})
    assert len(frames[-1].people) == 2        # one person, given twice
    got = unmatched(fusion)
    assert len(got['front']) == 1 and len(got['side']) == 1
    assert 'view side' in got['front'][0]
    assert 'view front' in got['side'][0]
    apart = float(re.search(r'\(([0-9.]+) m apart\)', got['front'][0])[1])
    assert abs(apart - 1.2) < 0.05
    name, level, message, _ = view_status(fusion, 'side')
    assert level == 1 and 'unmatched' in message
    # reported from 3 s on: about 2 s of the 5 at 30 Hz, for each view
    assert set(fusion.sightlines.instants) == {'front', 'side'}
    assert 50 <= fusion.sightlines.instants['front'] <= 62


def test_reported_only_after_it_lasts():
    person = body_at(0.0, 0.0)
    wrong = SensorPose(SIDE.x + 1.2, SIDE.y, SIDE.z, SIDE.yaw)
    fusion, _ = run(2.0, {'front': [person], 'side': [person]},
                    actual={'side': wrong})
    assert unmatched(fusion) == {'front': [], 'side': []}
    assert fusion.sightlines.pairs        # seen, not yet reported


def test_right_poses_one_person_nothing_reported():
    person = body_at(0.0, 0.0)
    fusion, frames = run(5.0, {'front': [person], 'side': [person]})
    assert len(frames[-1].people) == 1
    assert unmatched(fusion) == {'front': [], 'side': []}
    assert fusion.sightlines.instants == {}


def test_two_people_each_out_of_the_other_views_field():
    # each stands in its own view's field and 29-31 degrees off the other's
    a, b = body_at(1.8, 0.3), body_at(0.5, -1.5)
    for pose, own, other in ((FRONT, a, b), (SIDE, b, a)):
        assert in_sight(pose, own[:, :2].mean(axis=0), [], SightParams())
        assert not in_sight(pose, other[:, :2].mean(axis=0), [],
                            SightParams())
    fusion, frames = run(5.0, {'front': [a], 'side': [b]})
    assert len(frames[-1].people) == 2
    assert unmatched(fusion) == {'front': [], 'side': []}


def test_two_people_one_hidden_behind_the_other():
    # the side view's person stands between it and the front view's one
    hidden, near = body_at(0.0, 0.0), body_at(0.0, -1.5)
    fusion, frames = run(5.0, {'front': [hidden, near], 'side': [near]})
    # the front view sees both: they share a person, nothing to report
    assert unmatched(fusion) == {'front': [], 'side': []}
    fusion, frames = run(5.0, {'front': [hidden], 'side': [near]})
    assert unmatched(fusion) == {'front': [], 'side': []}


def test_sightlines_one_way_and_only_views_that_share_no_one():
    s = Sightlines(SightParams(after=0.0))
    a, b = body_at(1.8, 0.3), body_at(0.5, -1.5)     # out of each other's
    s.update(0.0, {1: (a, {'front'}), 2: (b, {'side'})}, POSES)
    assert s.disagreeing() == {}
    # side's person in front's sight, front's out of side's: one way
    b = body_at(0.0, -0.8)
    s.update(1.0, {1: (a, {'front'}), 2: (b, {'side'})}, POSES)
    got = s.disagreeing()
    assert set(got) == {'front', 'side'}
    assert math.isclose(got['front'][0][1], got['side'][0][1])
    # a third view that shares side's person: side is not alone
    poses = dict(POSES, back=facing(-3.0, 0.0, 1.0))
    s.update(2.0, {1: (a, {'front'}), 2: (b, {'side', 'back'})}, poses)
    assert s.disagreeing() == {}
