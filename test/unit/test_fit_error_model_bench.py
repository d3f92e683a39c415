"""bench/fit_error_model.py: what it records of the fusion, the fitted
trees exported for the fusion (they give what scikit-learn's model gives)
and written into the profile."""
import importlib.util
import os

import numpy as np
import yaml

from hri_sync.fusion.errors import INPUTS, ErrorModel
from hri_sync.fusion.frames import SensorPose
from hri_sync.fusion.fuse import FuseParams, Observation, fuse
from hri_sync.fusion.profile import Profile
from test_fusion_core import body
from test_fusion_errors import hands_on_the_trunk

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..',
                      '..', 'bench', 'fit_error_model.py')
spec = importlib.util.spec_from_file_location('fit_error_model', SCRIPT)
bench = importlib.util.module_from_spec(spec)
spec.loader.exec_module(bench)


def test_the_exported_trees_give_the_fitted_models_errors():
    rng = np.random.default_rng(7)
    x = rng.uniform(-1, 1, (4000, len(INPUTS)))
    x[rng.random(x.shape) < 0.05] = np.nan      # a torso missing
    rms = 0.05 * np.exp(np.nan_to_num(x[:, 4]) + (x[:, 1] > 0))
    err2 = (rms * rng.standard_normal(len(x))) ** 2
    far = rng.uniform(2.0, 4.0, len(x))
    model, fitted = bench.fit(np.column_stack([x, far, err2]))
    assert len(model.trees) == bench.TREES
    assert np.allclose(model.distances, (2.01, 3.99), atol=0.01)
    assert np.allclose(model.predict(x), fitted.predict(x), rtol=1e-9)
    again = ErrorModel.from_dict(model.to_dict())     # leaves to 1e-6
    assert np.allclose(again.predict(x), fitted.predict(x), rtol=1e-4)
    # what it learned: the error grows with the fifth input
    low, high = np.zeros((1, len(INPUTS))), np.zeros((1, len(INPUTS)))
    low[0, 4], high[0, 4] = -0.9, 0.9           # rms 6 times: 36 in m^2
    assert model.predict(high)[0] > 4 * model.predict(low)[0]


def test_the_motion_is_turned_and_mirrored_and_the_others_run_as_they_are():
    runs = bench.plan('salsa', ['punch'], [3, 4], 2, [0.0, 90.0], True)
    salsa = [r for r in runs if r[0] == 'salsa']
    assert len(salsa) == 2 * 2 * 2 * 2         # mirrored, turns, views, seeds
    assert {(r[3], r[4]) for r in salsa} == {
        (0.0, False), (90.0, False), (0.0, True), (90.0, True)}
    assert [r for r in runs if r[0] == 'punch'] == [
        ('punch', 4, 1, 0.0, False), ('punch', 4, 2, 0.0, False),
        ('punch', 3, 1, 0.0, False), ('punch', 3, 2, 0.0, False)]
    assert runs[0] == ('salsa', 4, 1, 0.0, False)   # most views first


def test_the_model_goes_into_the_profile_once_its_other_lines_kept():
    text = '# the profile\nsigma: 0.05\n# why\noffsets:\n- [0, 0, 0]\n'
    model = hands_on_the_trunk().to_dict()
    once = bench.with_block(text, 'errors', model, ['fit A'])
    twice = bench.with_block(once + 'delay: 0.1\n', 'errors', model,
                             ['fit B'])
    assert twice.startswith(text)
    assert twice.count('\nerrors:') == 1 and 'fit A' not in twice
    assert 'fit B' in twice and 'delay: 0.1' in twice
    loaded = yaml.safe_load(twice)
    assert ErrorModel.from_dict(loaded['errors']).predict(
        np.zeros((1, len(INPUTS))))[0] > 0


def test_the_recorder_keeps_the_joints_a_view_gives_with_their_error():
    truth = body()
    seen = truth + [0.0, 0.0, 0.1]
    seen[3] = np.nan                            # a joint it does not give
    confidence = np.full(15, 0.9)
    confidence[4] = 0.01                        # nor one below 0.05
    o = Observation('front', seen, confidence, np.zeros(15), 0.0,
                    sigma=0.05, power=0.5)
    rows = []
    inspect = bench.recorder(rows, {'front': SensorPose(3.0, 0.0, 1.0, 0.0)},
                             lambda t: truth[None], Profile(sigma=0.05))
    inspect(0.0, 1, [o], fuse([o], FuseParams()))
    (kept,) = rows
    assert kept.shape == (13, len(INPUTS) + 2)
    assert np.allclose(kept[:, -2], 3.0, atol=0.05)   # along the floor
    assert np.allclose(kept[:, -1], 0.01)       # (0.1 m) ** 2
    assert np.allclose(kept[:, INPUTS.index('log_sigma')],
                       np.log(0.05 * 0.9 ** -0.5))


def test_a_turned_motion_is_seen_from_another_side():
    from hri_sync.dance_off.joints import INDEX
    from hri_sync.dance_off.motion import Motion
    p = np.stack([body(), body() + [0.1, 0.0, 0.0]])
    motion = Motion([0.0, 0.1], p, name='dance')
    assert bench.turned(motion, 0.0) is motion
    quarter = bench.turned(motion, 90.0)
    assert quarter.name == 'dance_turn90'
    assert np.allclose(quarter.positions[..., 0], -p[..., 1])
    assert np.allclose(quarter.positions[..., 1], p[..., 0])
    assert np.allclose(quarter.positions[..., 2], p[..., 2])
    mirrored = bench.turned(motion, 0.0, mirrored=True)
    assert mirrored.name == 'dance_mirrored'
    left, right = INDEX['left_hand'], INDEX['right_hand']
    assert np.allclose(mirrored.positions[:, left],
                       p[:, right] * [1.0, -1.0, 1.0])
    assert np.allclose(mirrored.positions[:, INDEX['head']],
                       p[:, INDEX['head']] * [1.0, -1.0, 1.0])
    both = bench.turned(motion, 180.0, mirrored=True)
    assert both.name == 'dance_mirrored_turn180'
    assert np.allclose(both.positions[:, right],
                       p[:, left] * [-1.0, 1.0, 1.0])
