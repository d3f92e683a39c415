"""hri_sync.fusion.posture: a fused elbow taken with where the shoulder and
hand put it, as motion capture held its arms."""
import math

import numpy as np
import pytest
import yaml

from hri_sync.dance_off.joints import INDEX
from hri_sync.fusion.pipeline import Fusion
from hri_sync.fusion.posture import (Posture, arms_in_axes, fit_posture,
                                     shoulder_axes)
from hri_sync.fusion.profile import Profile
from test_fusion_core import body
from test_fusion_wrong_pose import ORIGINAL, POSES, dancer, run

ELBOW, HAND = INDEX['right_elbow'], INDEX['right_hand']
L_ELBOW, L_HAND = INDEX['left_elbow'], INDEX['left_hand']


def capture(frames=200):
    """Bodies (facing +x, left +y) whose arms swing forward and out: each
    elbow 0.3 m from its shoulder, each hand 0.3 m on from its elbow, the
    forearm bent forward by the swing; the left arm mirrors the right."""
    out = []
    for swing in np.linspace(0.0, 1.2, frames):
        p = body()
        for shoulder, elbow, hand, side in (
                ('right_shoulder', ELBOW, HAND, -1.0),
                ('left_shoulder', L_ELBOW, L_HAND, 1.0)):
            s = p[INDEX[shoulder]]
            upper = np.array([0.3 * math.sin(swing / 2),
                              side * 0.1 * swing, -0.3 * math.cos(swing / 2)])
            p[elbow] = s + 0.3 * upper / np.linalg.norm(upper)
            p[hand] = p[elbow] + 0.3 * np.array(
                [math.sin(swing), 0.0, -math.cos(swing)])
        out.append(p)
    return np.array(out)


def test_the_shoulders_axes_are_right_handed_and_need_the_trunk():
    axes = shoulder_axes(body())
    assert np.allclose(axes @ axes.T, np.eye(3))
    assert np.isclose(np.linalg.det(axes), 1.0)
    assert np.allclose(axes[0], [0, -1, 0])     # left shoulder to right
    assert np.allclose(axes[1], [0, 0, 1])      # up
    missing = body()
    missing[INDEX['neck']] = np.nan
    assert shoulder_axes(missing) is None


def test_the_left_arm_is_the_mirror_of_the_right():
    arms = arms_in_axes(capture(5))
    assert np.allclose(arms[:, 0], arms[:, 1])


def test_a_wrong_elbow_goes_to_where_the_shoulder_and_hand_put_it():
    posture = fit_posture(capture())
    truth = capture(7)[3]
    seen = truth.copy()
    seen[ELBOW] += [0.0, -0.25, 0.0]            # a guess out to the side
    sigma = np.full(15, 0.03)
    sigma[ELBOW] = 0.2                          # the views hardly see it
    placed = posture.place(seen, sigma)
    assert np.linalg.norm(placed[ELBOW] - truth[ELBOW]) < 0.02
    others = [j for j in range(15) if j not in (ELBOW, L_ELBOW)]
    assert np.array_equal(placed[others], seen[others])
    sigma[ELBOW] = 0.005                        # the views see it well
    kept = posture.place(seen, sigma)
    assert np.linalg.norm(kept[ELBOW] - seen[ELBOW]) < 0.02


def test_an_elbow_seen_well_far_from_the_prior_stays_nearly_put():
    posture = fit_posture(capture())
    seen = capture(7)[3]
    seen[ELBOW] += [0.0, -0.3, 0.0]             # the capture never had it
    sigma = np.full(15, 0.04)
    placed = posture.place(seen, sigma)
    assert np.linalg.norm(placed[ELBOW] - seen[ELBOW]) < 0.06
    ungated = Posture(posture.hands, posture.elbows, gate=math.inf)
    pulled = ungated.place(seen, sigma)
    assert np.linalg.norm(pulled[ELBOW] - seen[ELBOW]) > 0.15


def test_a_hand_unlike_any_captured_leaves_its_elbow_nearly_as_it_was():
    posture = fit_posture(capture())
    near, var_near = posture.prior(arms_in_axes(capture(7))[3, 1, 0])
    far, var_far = posture.prior(np.array([0.0, 0.6, 0.0]))    # overhead
    assert var_far > 20 * var_near
    seen = body()
    seen[HAND] = seen[INDEX['right_shoulder']] + [0.0, 0.0, 0.6]
    seen[ELBOW] = seen[INDEX['right_shoulder']] + [0.0, 0.0, 0.3]
    placed = posture.place(seen, np.full(15, 0.05))
    assert np.linalg.norm(placed[ELBOW] - seen[ELBOW]) < 0.03


def test_an_arm_with_a_joint_missing_is_left_as_it_is():
    posture = fit_posture(capture())
    seen = capture(7)[3] + [0.0, 0.0, 0.1]
    seen[HAND] = np.nan
    seen[L_ELBOW] = np.nan
    placed = posture.place(seen, np.full(15, 0.2))
    assert np.array_equal(placed, seen, equal_nan=True)


def test_the_posture_rides_in_the_profile():
    posture = fit_posture(capture())
    values = yaml.safe_load(yaml.safe_dump(Profile(posture=posture)
                                           .to_dict()))
    again = Profile.from_dict(values).posture
    assert np.allclose(again.hands, posture.hands, atol=5e-4)
    assert again.sigma == posture.sigma
    assert Fusion(POSES, profiles={v: Profile.from_dict(values)
                                   for v in POSES}).posture is not None
    assert Fusion(POSES).posture is None


@pytest.mark.parametrize('bad', [
    {'arms': [[0, 1, 2, 3, 4]] * 10},
    {'arms': [[0, 1, 2, 3, 4, 5]] * 3},
    {'arms': [[0, 1, 2, 3, 4, float('nan')]] * 10},
    {'arms': [[0, 1, 2, 3, 4, 5]] * 10, 'sigma': 0},
    {'arms': [[0, 1, 2, 3, 4, 5]] * 10, 'gate': 0},
    {'arms': [[0, 1, 2, 3, 4, 5]] * 10, 'spread': 1},
])
def test_a_malformed_posture_is_refused(bad):
    with pytest.raises(ValueError):
        Posture.from_dict(bad)


def test_a_fitted_posture_holds_both_arms_of_every_whole_frame():
    frames = capture(10)
    frames[2, HAND] = np.nan
    posture = fit_posture(frames)
    assert len(posture.hands) == 19
    assert np.isfinite(posture.elbows).all()


def test_the_fusion_takes_its_elbows_with_the_posture_and_widens_the_bound():
    motion = dancer()
    truth = np.array([ORIGINAL.to_world(p) for p in motion.positions])
    profile = Profile(sigma=0.05, posture=fit_posture(truth))

    def guessed(view, t):
        """Every view guesses the right elbow 0.2 m too far out."""
        world = ORIGINAL.to_world(motion.positions_at([t])[0])
        world[ELBOW] += 0.2 * np.array([0.0, 0.0, 1.0])
        return world

    published = {}
    for name, profiles in (('with', {v: profile for v in POSES}),
                           ('without', None)):
        _, frames = run(3.0, {}, [guessed], profiles=profiles)
        published[name] = [(f.stamp, f.people[0].body) for f in frames
                           if f.people and f.stamp >= 1.0]
    off = {name: np.mean([np.linalg.norm(
        body.positions[ELBOW] - ORIGINAL.to_world(
            motion.positions_at([t])[0])[ELBOW]) for t, body in bodies])
        for name, bodies in published.items()}
    assert off['with'] < off['without'] - 0.05
    for (_, body), (_, plain) in zip(published['with'],
                                     published['without']):
        moved = np.linalg.norm(body.positions[ELBOW] - plain.positions[ELBOW])
        assert body.bound[ELBOW] >= plain.bound[ELBOW] + moved - 0.02
