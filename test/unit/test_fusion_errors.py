"""hri_sync.fusion.errors: a view's joint error from where the joint lies
(the model's inputs, its trees, its checks), and the fusion weighing the
views by it."""
import math

import numpy as np
import pytest

from hri_sync.dance_off.joints import INDEX
from hri_sync.fusion.errors import INPUTS, ErrorModel, Tree, inputs
from hri_sync.fusion.facing import back_view, back_views
from hri_sync.fusion.frames import SensorPose
from hri_sync.fusion.pipeline import Fusion, FusionParams
from hri_sync.fusion.profile import Profile
from test_fusion_core import body

HAND = INDEX['right_hand']
KIND, ACROSS_FLOOR = INPUTS.index('kind'), INPUTS.index('across_floor')


def hands_on_the_trunk():
    """A model: a hand within 0.1 m of the line from the torso to the
    sensor (along the floor) errs 0.3 m rms, every other joint 0.05 m."""
    small, big = math.log(0.05 ** 2), math.log(0.3 ** 2)
    return ErrorModel(0.0, [Tree(
        feature=np.array([KIND, -1, ACROSS_FLOOR, -1, -1]),
        threshold=np.array([2.5, 0.0, 0.1, 0.0, 0.0]),
        left=np.array([1, 0, 3, 0, 0]), right=np.array([2, 0, 4, 0, 0]),
        value=np.array([0.0, small, 0.0, big, small]),
        missing_left=np.array([False, False, True, False, False]))])


def test_the_inputs_say_where_a_joint_lies_towards_and_across_the_sensor():
    truth = body()
    truth[HAND] = [0.5, -0.2, 1.5]              # torso at (0, 0, 1.2)
    sensor = np.array([3.0, 0.0, 1.0])
    x = inputs(truth, np.full(15, 0.02), np.full(15, 0.05), truth,
               sensor, back_view(truth, sensor))
    row = dict(zip(INPUTS, x[HAND]))
    assert row['toward'] == pytest.approx(0.5)
    assert row['across'] == pytest.approx(math.hypot(0.2, 0.3))
    assert row['across_floor'] == pytest.approx(0.2)
    assert row['kind'] == 3 and x[INDEX['left_elbow'], KIND] == 2
    assert row['log_confidence'] == pytest.approx(math.log(0.05))
    assert row['log_sigma'] == pytest.approx(math.log(0.05))
    assert x.shape == (15, len(INPUTS))
    assert row['back'] == pytest.approx(0.0)


def test_the_inputs_say_how_much_of_the_back_the_view_sees():
    truth = body()
    sensor = np.array([-3.0, 0.0, 1.0])         # behind the body
    back = inputs(truth, np.ones(15), np.full(15, 0.05), truth, sensor,
                  back_view(truth, sensor))
    assert back[:, INPUTS.index('back')] == pytest.approx(np.ones(15))
    truth[INDEX['left_hip']] = np.nan           # no front to tell
    unknown = inputs(truth, np.ones(15), np.full(15, 0.05), truth, sensor,
                     back_view(truth, sensor))
    assert np.isnan(unknown[:, INPUTS.index('back')]).all()


def test_every_views_back_is_found_at_once_as_one_at_a_time():
    truth = body()
    sensors = [np.array(s, float) for s in
               ((3, 0, 1), (0, 3, 1), (-3, 0, 1), (-2, -2, 1))]
    assert back_views(truth, sensors) == [back_view(truth, s)
                                          for s in sensors]
    truth[INDEX['left_hip']] = np.nan
    assert back_views(truth, sensors) == [None] * 4


def test_trees_route_rows_and_missing_values_and_sum_in_the_log():
    model = hands_on_the_trunk()
    x = np.zeros((4, len(INPUTS)))
    x[:, KIND] = [0, 3, 3, 3]
    x[:, ACROSS_FLOOR] = [0.0, 0.05, 0.3, np.nan]
    assert np.sqrt(model.predict(x)) == pytest.approx([0.05, 0.3, 0.05, 0.3])
    twice = ErrorModel(1.0, model.trees * 2)
    assert twice.predict(x) == pytest.approx(math.e * model.predict(x) ** 2)


def test_many_rows_are_walked_a_slice_at_a_time(monkeypatch):
    from hri_sync.fusion import errors
    rng = np.random.default_rng(3)
    x = rng.uniform(-1, 1, (2500, len(INPUTS)))
    x[rng.random(x.shape) < 0.05] = np.nan
    model = hands_on_the_trunk()
    whole = model.predict(x)
    monkeypatch.setattr(errors, 'ROWS', 1000)
    assert np.array_equal(model.predict(x), whole)


def test_a_model_round_trips_and_a_broken_one_is_refused():
    model = hands_on_the_trunk()
    again = ErrorModel.from_dict(model.to_dict())
    x = np.random.default_rng(1).uniform(0, 4, (50, len(INPUTS)))
    assert again.predict(x) == pytest.approx(model.predict(x))
    d = model.to_dict()
    for broken, why in (({'inputs': ['confidence']}, 'takes the inputs'),
                        ({'trees': []}, 'one tree'),
                        ({'baseline': float('nan')}, 'finite baseline')):
        with pytest.raises(ValueError, match=why):
            ErrorModel.from_dict({**d, **broken})
    looped = {**d, 'trees': [dict(d['trees'][0], left=[0, 0, 3, 0, 0])]}
    with pytest.raises(ValueError, match='not a tree'):
        ErrorModel.from_dict(looped)
    short = {**d, 'trees': [{k: v for k, v in d['trees'][0].items()
                             if k != 'missing_left'}]}
    with pytest.raises(ValueError, match='lacks'):
        ErrorModel.from_dict(short)
    for distances in (None, [3.0, 2.0], [-1.0, 2.0]):
        with pytest.raises(ValueError, match='distances'):
            ErrorModel.from_dict({**d, 'distances': distances})


def test_a_model_fitted_before_an_input_was_added_takes_the_first():
    d = hands_on_the_trunk().to_dict()
    older = ErrorModel.from_dict({**d, 'inputs': list(INPUTS[:6])})
    x = np.random.default_rng(2).uniform(0, 4, (50, len(INPUTS)))
    assert older.predict(x) == pytest.approx(
        hands_on_the_trunk().predict(x))
    assert older.to_dict()['inputs'] == list(INPUTS[:6])
    with pytest.raises(ValueError, match='not a tree'):
        ErrorModel.from_dict({**d, 'inputs': list(INPUTS[:KIND])})
    with pytest.raises(ValueError, match='takes the inputs'):
        ErrorModel.from_dict({**d, 'inputs': list(INPUTS[1:])})


def test_a_profile_carries_its_error_model():
    profile = Profile(sigma=0.05, errors=hands_on_the_trunk())
    again = Profile.from_dict(profile.to_dict())
    assert again.errors is not None
    assert len(again.errors.trees) == 1
    assert Profile.from_dict(Profile().to_dict()).errors is None
    with pytest.raises(ValueError, match='error model'):
        Profile.from_dict({'errors': {'inputs': list(INPUTS)}})


POSES = {'front': SensorPose(3.0, 0.0, 1.0, math.pi),
         'diagonal': SensorPose(-2.1, 2.1, 1.0, -math.pi / 4)}


def fused_hand(errors, seconds=1.0, rate=30.0):
    """The fused right hand's error (m) of two views of a still person at
    confidence 0.9: 'front' lays the hand on the trunk, on its line of
    sight (0.3 m off), 'diagonal' has it right; 5 mm noise."""
    truth = body()
    wrong = truth.copy()
    wrong[HAND] += [0.0, 0.3, 0.0]
    rng = np.random.default_rng(4)
    clock = {'now': 0.0}
    fusion = Fusion(POSES, FusionParams(), lambda: clock['now'],
                    {v: Profile(sigma=0.05, errors=errors) for v in POSES})
    frames = []
    for k in range(int(seconds * rate)):
        t = k / rate
        clock['now'] = t + 0.05
        for view, pose in POSES.items():
            seen = wrong if view == 'front' else truth
            fusion.add(view, 1, t, pose.from_world(seen)
                       + rng.normal(0, 0.005, (15, 3)), np.full(15, 0.9),
                       0.001)
        frames += fusion.poll()
    return float(np.linalg.norm(frames[-1].people[0].body.positions[HAND]
                                - truth[HAND]))


def test_the_fusion_weighs_a_hand_on_the_trunk_by_the_error_model():
    assert fused_hand(None) > 0.12         # half way between the views
    assert fused_hand(hands_on_the_trunk()) < 0.03
    # views 3 m from the person, a model that knows views up to 2.5 m
    near = hands_on_the_trunk()
    near.distances = (0.5, 2.5)
    assert fused_hand(near) > 0.12


def test_the_model_weighs_the_views_the_profile_keeps_their_level():
    """The model says how the views compare on a joint; the bound stays
    the profile's size (geometric mean over the views)."""
    def bound(errors):
        truth = body()
        truth[HAND] = [0.3, -0.02, 1.0]     # on the front view's line
        clock = {'now': 0.0}
        fusion = Fusion(POSES, FusionParams(), lambda: clock['now'],
                        {v: Profile(sigma=0.05, errors=errors)
                         for v in POSES})
        frames = []
        for k in range(15):
            clock['now'] = k / 30.0 + 0.05
            for view, pose in POSES.items():
                fusion.add(view, 1, k / 30.0, pose.from_world(truth)
                           + 1e-6 * k, np.full(15, 0.9), 0.001)
            frames += fusion.poll()
        return frames[-1].people[0].body.bound
    flat = bound(None)
    modelled = bound(hands_on_the_trunk())
    # the hand: 0.3 m rms in the front view, 0.05 in the other, both
    # rescaled to the profile's level (their geometric mean), the better
    # one weighing most: the fused hand's error is less than the profile's
    assert modelled[HAND] < 0.7 * flat[HAND]
    assert modelled[INDEX['torso']] == pytest.approx(flat[INDEX['torso']])
