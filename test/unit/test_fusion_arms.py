"""hri_sync.fusion.arms: a view whose tracker exchanged the left and right
arms, or took the body's back for its front, is put right when both the
person's predicted body and the person's other views say so, never on
one of them alone, and counted."""
import math

import numpy as np
import pytest

from hri_sync.dance_off.joints import INDEX, NUM_JOINTS
from hri_sync.fusion.arms import (BODY_LEFT, BODY_RIGHT, ArmParams,
                                  arms_to_exchange, bodies_to_turn,
                                  exchanged, turned)
from hri_sync.fusion.facing import FacingParams
from hri_sync.fusion.frames import SensorPose, parse_pose
from hri_sync.fusion.fuse import FuseParams, Observation
from hri_sync.fusion.pipeline import FusionParams
from hri_sync.fusion.profile import ARMS
from hri_sync.fusion.report import view_status
from test_fusion_core import body
from test_fusion_wrong_pose import ORIGINAL, dancer, run as feed

RNG = np.random.default_rng(38)


def views(names, swapped=(), swap=exchanged):
    truth = body()
    out = []
    for v in names:
        p = truth + RNG.normal(0, 0.01, truth.shape)
        out.append(Observation(v, swap(p) if v in swapped else p,
                               np.full(NUM_JOINTS, 0.8), np.zeros(NUM_JOINTS),
                               0.001))
    return out


def decide(obs, predicted):
    return dict(zip([o.view for o in obs], arms_to_exchange(
        obs, predicted, ArmParams(), FuseParams())))


def test_exchanged_swaps_only_the_elbows_and_hands():
    p = body()
    q = exchanged(p)
    assert np.array_equal(q[INDEX['left_hand']], p[INDEX['right_hand']])
    assert np.array_equal(q[INDEX['right_elbow']], p[INDEX['left_elbow']])
    rest = [j for j in range(NUM_JOINTS) if j not in ARMS]
    assert np.array_equal(q[rest], p[rest])
    assert np.array_equal(exchanged(q), p)


def test_the_view_both_references_blame_is_exchanged():
    obs = views('abcd', swapped='c')
    assert decide(obs, body()) == {'a': False, 'b': False, 'c': True,
                                   'd': False}


def test_one_reference_alone_exchanges_nothing():
    # The prediction went wrong (it carries exchanged arms): the other
    # views do not agree, so nothing is exchanged.
    obs = views('abcd')
    assert not any(decide(obs, exchanged(body())).values())
    # The other views blame 'c', but the prediction carries c's labels:
    # c is left as it is.
    obs = views('abcd', swapped='c')
    assert not any(decide(obs, exchanged(body())).values())
    # Three views exchanged together: the fourth, right one, is left alone
    # though the other views blame it; the three are blamed by the
    # prediction but not by their others (two of which exchanged too).
    obs = views('abcd', swapped='abc')
    assert not any(decide(obs, body()).values())
    # The wrong prediction blames one view alone: the others hold their
    # hands together in front, so their body says nothing of its labels.
    obs = views('abcd')
    for o in obs:
        if o.view != 'c':
            for side in ('left', 'right'):
                o.positions[INDEX[side + '_elbow']] = (0.2, 0.0, 1.15)
                o.positions[INDEX[side + '_hand']] = (0.4, 0.0, 1.2)
    assert not any(decide(obs, exchanged(body())).values())


def test_nothing_without_a_prediction_or_with_three_views():
    assert not any(decide(views('abcd', swapped='c'), None).values())
    assert not any(decide(views('abc', swapped='c'), body()).values())


def test_hands_close_together_are_not_exchanged_for_noise():
    obs = views('abcd', swapped='c')
    for o in obs:
        o.positions[INDEX['left_hand']] = o.positions[INDEX['right_hand']] \
            + [0, 0.02, 0]
        o.positions[INDEX['left_elbow']] = o.positions[INDEX['right_elbow']] \
            + [0, 0.02, 0]
    assert not any(decide(obs, body()).values())


POSES = {'front': SensorPose(3.3, 0.0, 1.0, math.pi),
         'left': parse_pose('0.0 3.3 1.0 -1.571'),
         'back': SensorPose(-3.3, 0.0, 1.0, 0.0),
         'right': parse_pose('0.0 -3.3 1.0 1.571')}


def run(arms, swap_from=2.0, swap_to=4.0, seconds=6.0, swap=exchanged,
        swapped=('back',), facing=FacingParams(), alter=None):
    """A Fusion of four views of the salsa dancer (1 cm noise, 50 ms
    late); the ``swapped`` views' trackers exchange the arms (``swap``)
    from ``swap_from`` to ``swap_to`` s; every view sees ``alter(t, p)``
    of the dancer's joints ``p`` where given. Returns the fusion, its
    frames and the truth."""
    motion = dancer()

    def truth(t):
        return ORIGINAL.to_world(motion.positions_at([t])[0])

    def seen(view, t):
        p = truth(t) if alter is None else alter(t, truth(t))
        return swap(p) if view in swapped and swap_from <= t < swap_to \
            else p
    fusion, frames = feed(seconds, {}, [seen], poses=POSES,
                          params=FusionParams(arms=arms, facing=facing))
    return fusion, frames, truth


def hand_error(frames, truth, t0, t1, joints=ARMS):
    return np.mean([np.linalg.norm(
        f.people[0].body.positions[joints] - truth(f.stamp)[joints], axis=1)
        for f in frames if f.people and t0 <= f.stamp < t1])


@pytest.mark.parametrize('swap, off, counter, label, joints', [
    (exchanged, ArmParams(margin=math.inf), 'arms_exchanged',
     'arms exchanged back', ARMS),
    (turned, ArmParams(turn_margin=math.inf), 'turned_back', 'turned back',
     BODY_LEFT + BODY_RIGHT)])
def test_a_view_put_right_is_counted_and_fused_nearer(swap, off, counter,
                                                       label, joints):
    # The hands, or the head, would turn the back view first
    # (hri_sync.fusion.facing).
    no_hands = FacingParams(margin=math.inf, split_head_margin=math.inf)
    fusion, frames, truth = run(ArmParams(), swap=swap, facing=no_hands)
    kept, kept_frames, _ = run(off, swap=swap, facing=no_hands)
    during = sum(1 for f in frames if 2.0 <= f.stamp < 4.0)
    counted = getattr(fusion.health['back'], counter)
    assert 0.8 * during <= counted <= during
    assert all(getattr(fusion.health[v], counter) == 0
               for v in ('front', 'left', 'right'))
    assert getattr(kept.health['back'], counter) == 0
    assert hand_error(frames, truth, 2.0, 4.0, joints) \
        < hand_error(kept_frames, truth, 2.0, 4.0, joints)
    _, _, _, values = view_status(fusion, 'back')
    assert (label, str(counted)) in values


def test_turned_exchanges_every_left_and_right_joint():
    p = body()
    q = turned(p)
    assert np.array_equal(q[BODY_LEFT], p[BODY_RIGHT])
    assert np.array_equal(q[BODY_RIGHT], p[BODY_LEFT])
    for j in ('head', 'neck', 'torso'):
        assert np.array_equal(q[INDEX[j]], p[INDEX[j]])


def test_a_view_that_took_the_back_for_the_front_is_turned_with_three():
    obs = views('abc', swapped='c', swap=turned)
    assert bodies_to_turn(obs, body(), ArmParams(), FuseParams()) \
        == [False, False, True]
    # Its arms alone are not judged with three views.
    assert not any(decide(obs, body()).values())
    # Two of three turned: no majority; nor without a prediction.
    obs = views('abc', swapped='bc', swap=turned)
    assert not any(bodies_to_turn(obs, body(), ArmParams(), FuseParams()))
    assert not any(bodies_to_turn(views('abc', swapped='c', swap=turned),
                                  None, ArmParams(), FuseParams()))
    # A view whose arms alone are exchanged is not turned.
    obs = views('abcd', swapped='c')
    assert not any(bodies_to_turn(obs, body(), ArmParams(), FuseParams()))
