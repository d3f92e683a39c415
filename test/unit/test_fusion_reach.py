"""hri_sync.fusion: a view's hand that no fused arm reaches is left out
(reach), and a joint no view sees is fused from the views' guesses at
confidence 0 (fuse)."""
import math

import numpy as np

from hri_sync.dance_off.joints import INDEX
from hri_sync.fusion.frames import SensorPose
from hri_sync.fusion.fuse import FuseParams, Observation, fuse
from hri_sync.fusion.pipeline import Fusion, FusionParams
from hri_sync.fusion.reach import ReachParams, out_of_reach
from hri_sync.fusion.report import view_status
from test_fusion_core import body

HAND, ELBOW = INDEX['right_hand'], INDEX['right_elbow']
POSES = {'behind': SensorPose(3.0, 0.0, 1.0, math.pi),
         'side': SensorPose(0.0, 3.0, 1.0, -math.pi / 2),
         'front': SensorPose(-2.0, 0.0, 1.0, 0.0)}
OFF = np.array([0.0, -0.8, 0.0])        # the front view's guess of the hand


def seen(positions, confidence=0.9, **joints):
    """An observation of ``positions``, its ``joints`` (name=(confidence,
    offset)) at their own confidence and moved by their offset."""
    p, c = positions.copy(), np.full(15, confidence)
    for name, (conf, offset) in joints.items():
        c[INDEX[name]] = conf
        p[INDEX[name]] += offset
    return Observation('v', p, c, np.zeros(15), 0.0)


def test_a_hand_far_from_the_fused_elbow_is_out_of_reach():
    truth = body()
    views = [seen(truth), seen(truth, right_hand=(0.3, OFF))]
    masks = out_of_reach(views, truth, ReachParams())
    assert not masks[0].any()
    assert masks[1][HAND] and masks[1].sum() == 1


def test_a_hand_another_view_seconds_is_kept():
    truth = body()
    near = OFF + [0.0, 0.1, 0.0]
    views = [seen(truth, right_hand=(0.3, OFF)),
             seen(truth, right_hand=(0.9, near))]
    assert not any(m.any() for m in out_of_reach(views, truth,
                                                 ReachParams()))


def test_without_a_fused_elbow_no_hand_is_judged():
    truth = body()
    elbowless = truth.copy()
    elbowless[ELBOW] = np.nan
    views = [seen(truth, right_hand=(0.3, OFF))]
    assert not out_of_reach(views, elbowless, ReachParams())[0].any()


def test_a_joint_no_view_sees_comes_from_their_guesses_at_confidence_0():
    truth = body()
    guessed = [seen(truth, right_hand=(0.0, 0.0)),
               seen(truth, right_hand=(0.02, [0.0, 0.1, 0.0]))]
    fused = fuse(guessed, FuseParams())
    assert np.linalg.norm(fused.positions[HAND] - truth[HAND]) < 0.1
    assert fused.confidence[HAND] == 0.0
    assert fused.confidence[ELBOW] == 0.9
    assert np.isfinite(fused.bound[HAND])
    gone = seen(truth)
    gone.positions[HAND] = np.nan
    assert np.isnan(fuse([gone], FuseParams()).positions[HAND]).all()


def run(hand_reach, seconds=2.0, rate=30.0):
    """A Fusion (``hand_reach`` m) over ``seconds`` of three views of a
    still person: 'behind' and 'side' see all but the right hand, which
    they give right at confidence 0 (just outside their images); 'front'
    guesses it 0.8 m off at confidence 0.3; 5 mm noise."""
    truth = body()
    rng = np.random.default_rng(3)
    clock = {'now': 0.0}
    fusion = Fusion(POSES, FusionParams(), lambda: clock['now'])
    fusion.params.reach.hand = hand_reach
    frames = []
    for k in range(int(seconds * rate)):
        t = k / rate
        clock['now'] = t + 0.05
        for view, pose in POSES.items():
            o = seen(truth, right_hand=(0.3, OFF) if view == 'front'
                     else (0.0, 0.0))
            fusion.add(view, 1, t, pose.from_world(o.positions)
                       + rng.normal(0, 0.005, (15, 3)), o.confidence, 0.001)
        frames += fusion.poll()
    hand = frames[-1].people[0].body
    return fusion, float(np.linalg.norm(hand.positions[HAND]
                                        - truth[HAND])), hand.confidence[HAND]


def test_a_guessed_hand_no_arm_reaches_is_left_out_and_counted():
    fusion, error, confidence = run(0.5)
    _, unchecked, _ = run(math.inf)
    assert unchecked > 0.6              # the front view's guess
    assert error < 0.05 and confidence == 0.0
    assert fusion.health['front'].out_of_reach > 0
    assert fusion.health['side'].out_of_reach == 0
    _, _, _, values = view_status(fusion, 'front')
    assert ('hands out of reach',
            str(fusion.health['front'].out_of_reach)) in values
