"""hri_sync.fusion.facing: where the views disagree on which way a person
faces, those facing away from where the hands reach are turned; hands at
the trunk, views that agree, or hands no view sees well decide nothing;
views that all agree against the head, on straight legs, are turned to
it; the labels are sure only where the hands decide."""
import math

import numpy as np
import pytest

from hri_sync.dance_off.joints import INDEX, NUM_JOINTS
from hri_sync.fusion.arms import (BODY_LEFT, BODY_RIGHT, TRUNK, ArmParams,
                                  turned)
from hri_sync.fusion.facing import (FacingParams, HeldFront, either_side,
                                    front, views_to_turn)
from hri_sync.fusion.fuse import Observation
from hri_sync.fusion.report import people_status, view_status
from test_fusion_arms import POSES, hand_error, run
from test_fusion_core import body

RNG = np.random.default_rng(65)
HANDS = ('left_hand', 'right_hand')


def reaching(forward=0.3):
    """The standing body (facing +x) with its hands ``forward`` m in
    front of its trunk."""
    p = body()
    for hand in HANDS:
        p[INDEX[hand]] += (forward, 0.0, 0.3)
    return p


def views(names, turned_views=(), forward=0.3, confidence=0.8):
    truth = reaching(forward)
    out = []
    for v in names:
        p = truth + RNG.normal(0, 0.01, truth.shape)
        c = np.full(NUM_JOINTS, 0.8)
        c[[INDEX[h] for h in HANDS]] = confidence
        out.append(Observation(v, turned(p) if v in turned_views else p, c,
                               np.zeros(NUM_JOINTS), 0.001))
    return out


def decide(obs, params=FacingParams(), held=None):
    decision = views_to_turn(obs, params, held)
    return [o.view for o, yes in zip(obs, decision.turn) if yes]


def test_front_is_the_way_the_labels_face():
    assert np.allclose(front(body()), (1, 0, 0))
    assert np.allclose(front(turned(body())), (-1, 0, 0))
    nan = body()
    nan[INDEX['left_hip']] = np.nan
    assert front(nan) is None
    # Hips 5 cm apart (every joint at one point, and noise) tell no side.
    narrow = body()
    narrow[INDEX['left_hip'], 1] = narrow[INDEX['right_hip'], 1] + 0.05
    assert front(narrow) is None


def test_the_views_facing_away_from_the_hands_are_turned_however_many():
    assert decide(views('abcd', turned_views='bcd')) == ['b', 'c', 'd']
    assert decide(views('abc', turned_views='a')) == ['a']
    assert decide(views('ab', turned_views='b')) == ['b']


def test_hands_behind_decide_the_other_way():
    # The hands are what decides, not the count: reaching back, the
    # three views that face the other way are right.
    assert decide(views('abcd', turned_views='a', forward=-0.3)) \
        == ['b', 'c', 'd']


def test_the_front_the_hands_decide_is_given_and_held_where_they_do_not():
    decision = views_to_turn(views('abc', turned_views='bc'),
                             FacingParams())
    decided = decision.front
    assert np.allclose(decided, (1, 0, 0), atol=0.05)
    assert not decision.unsure
    hanging = views('abc', turned_views='bc', forward=0.0)
    assert decide(hanging) == []
    assert views_to_turn(hanging, FacingParams()).unsure
    assert decide(hanging, held=decided) == ['b', 'c']
    assert decide(hanging, held=-decided) == ['a']
    # A held front across the views' axis says neither way.
    assert decide(hanging, held=np.array([0.0, 1.0, 0.0])) == []
    # The held front's labels are in doubt: the hands said it before.
    held = views_to_turn(hanging, FacingParams(), decided)
    assert held.front is None and held.unsure and not held.by_head


def test_a_front_is_held_once_the_hands_said_it_twice_within_a_second():
    deciding = views('abc', turned_views='bc')
    hanging_hands = views('abc', turned_views='bc', forward=0.0)
    held = HeldFront(FacingParams(hold=3.0))
    assert held.views_to_turn(0.0, deciding).turn == [False, True, True]
    # Said once: not held (one instant can be a tracker's lone glitch).
    assert held.views_to_turn(0.1, hanging_hands).turn == [False] * 3
    # Said again 1.5 s later: the first is too old to confirm it.
    held.views_to_turn(1.5, deciding)
    assert held.views_to_turn(1.6, hanging_hands).turn == [False] * 3
    # Twice within a second: held for the next 3 s, then no longer.
    held.views_to_turn(1.9, deciding)
    assert held.views_to_turn(4.8, hanging_hands).turn == [False, True, True]
    assert held.views_to_turn(5.0, hanging_hands).turn == [False] * 3


def held_forwards():
    """A HeldFront the hands confirmed facing +x."""
    held = HeldFront(FacingParams())
    for t in (0.0, 0.1):
        held.views_to_turn(t, views('abc', turned_views='bc'))
    return held


def test_the_held_front_turns_with_the_fused_body():
    held = held_forwards()
    # The person has turned about: the views still disagree, and the
    # held front, turned with the fused body, now sides with b and c.
    held.turn_with(turned(body()))
    assert np.allclose(held.front, (-1, 0, 0))
    assert held.views_to_turn(0.2, views(
        'abc', turned_views='bc', forward=0.0)).turn == [True, False, False]
    # A fused body without hips leaves it as it was.
    flat = body()
    flat[INDEX['left_hip']] = np.nan
    held.turn_with(flat)
    assert np.allclose(held.front, (-1, 0, 0))


def test_hands_against_a_held_front_decide_only_said_twice_in_a_second():
    held = held_forwards()
    # The hands say the back is the front (a kick's drawn-back hands, or a
    # tracker's slip): once, the held front decides, the labels in doubt.
    slip = views('abc', turned_views='bc', forward=-0.3)
    for t in (0.5, 2.0):    # 1.5 s apart: the first too old to confirm
        decision = held.views_to_turn(t, slip)
        assert decision.turn == [False, True, True]
        assert decision.front is None and decision.unsure
        assert np.allclose(decision.against, (-1, 0, 0), atol=0.05)
    # Again within a second, but the hands said the held front between:
    # held off again.
    held.views_to_turn(2.2, views('abc', turned_views='bc'))
    assert held.views_to_turn(2.4, slip).front is None
    # Again within a second: they decide, and their front is held.
    decision = held.views_to_turn(2.5, slip)
    assert decision.turn == [True, False, False] and not decision.unsure
    hanging = views('abc', turned_views='bc', forward=0.0)
    assert held.views_to_turn(2.6, hanging).turn == [True, False, False]
    # Without a held front, the hands decide at once.
    assert views_to_turn(slip, FacingParams(), None, overrule=False).turn \
        == [True, False, False]


def test_hands_against_a_held_front_decide_only_said_more_often_than_it():
    held = held_forwards()
    deciding = views('abc', turned_views='bc')
    slip = views('abc', turned_views='bc', forward=-0.3)
    for t in (0.2, 0.3, 0.4):           # the hands say the held front ...
        held.views_to_turn(t, deciding)
    # ... then the other side (a kick's arms swung back), once, twice,
    # three times: the held front, said at more instants of the last
    # second, decides.
    for t in (1.0, 1.05, 1.1):
        assert held.views_to_turn(t, slip).front is None
    # A fourth time, more often than the held front in the last second
    # (0.2, 0.3, 0.4; 0.0 and 0.1 have aged out): they decide.
    decision = held.views_to_turn(1.15, slip)
    assert decision.turn == [True, False, False] and not decision.unsure


def test_a_held_front_the_fused_body_turned_about_is_not_the_hands():
    held = held_forwards()
    deciding = views('abc', turned_views='bc')
    for t in (0.2, 0.3, 0.4):
        held.views_to_turn(t, deciding)
    # The fused body's labels were exchanged (views that agreed, wrong):
    # its front points the other way one instant later, and the held front
    # with it, but the hands never said that front.
    held.turn_with(turned(body()))
    assert np.allclose(held.front, (-1, 0, 0))
    assert held.views_to_turn(0.5, deciding).front is None
    decision = held.views_to_turn(0.55, deciding)
    assert decision.turn == [False, True, True] and not decision.unsure
    # Turned 60 degrees (the person turning), it keeps their decisions.
    held = held_forwards()
    for t in (0.2, 0.3, 0.4):
        held.views_to_turn(t, deciding)
    c, s = math.cos(math.radians(60)), math.sin(math.radians(60))
    turning = body()
    turning[:, :2] = turning[:, :2] @ np.array([[c, s], [-s, c]])
    held.turn_with(turning)
    assert held.front @ (1, 0, 0) == pytest.approx(0.5, abs=0.05)
    assert len(held.times) == 5


@pytest.mark.parametrize('kwargs', [
    dict(turned_views='bc', forward=0.05),      # hands at the trunk
    dict(turned_views=''),                      # the views agree
    dict(turned_views='abcd'),                  # agree, though wrong
    dict(turned_views='bc', confidence=0.3)])   # hands not seen well
def test_nothing_is_decided(kwargs):
    assert decide(views('abcd', **kwargs)) == []


def test_a_bound_in_doubt_takes_in_the_other_side():
    p = reaching()
    bound = np.full(NUM_JOINTS, 0.05)
    grown = either_side(p, bound)
    left, right = INDEX['left_hand'], INDEX['right_hand']
    width = np.linalg.norm(p[left] - p[right])
    assert grown[left] == pytest.approx(width + 0.05)
    assert grown[right] == pytest.approx(width + 0.05)
    for j in ('head', 'neck', 'torso'):
        assert grown[INDEX[j]] == 0.05
    # A joint not fused keeps its bound (NaN).
    p[left] = np.nan
    bound[right] = np.nan
    grown = either_side(p, bound)
    assert np.isnan(grown[right]) and grown[left] == 0.05


def test_one_view_alone_seeing_the_hands_decides_nothing():
    obs = views('abc', turned_views='bc')
    for o in obs[1:]:
        o.confidence[[INDEX[h] for h in HANDS]] = 0.2
    assert decide(obs) == []
    assert decide(obs, FacingParams(views=1)) == ['b', 'c']


def test_a_side_view_is_not_taken_for_either_way():
    obs = views('abc', turned_views='b')
    side = obs[2].positions
    centre = side[INDEX['torso']].copy()
    # The third view's body faces +y: its labels say neither way. (Its
    # hands stay where they are.)
    rotated = (side - centre) @ np.array([[0, 1, 0], [-1, 0, 0], [0, 0, 1]])
    hands = [INDEX[h] for h in HANDS]
    rotated[hands] = side[hands] - centre
    obs[2].positions = rotated + centre
    assert decide(obs) == ['b']


def test_a_hand_drawn_back_behind_the_trunk_decides_nothing():
    # One hand punches 0.4 m forward, the other is drawn back 0.15 m
    # behind the trunk: on average in front, but the hands point both ways.
    obs = views('abcd', turned_views='bcd', forward=0.0)
    for o in obs:
        for hand, forward in (('left_hand', 0.4), ('right_hand', -0.15)):
            o.positions[INDEX[hand], 0] += forward
    assert decide(obs) == []
    assert views_to_turn(obs, FacingParams()).unsure
    # Drawn back less than the margin, it leaves the front to the other.
    for o in obs:
        o.positions[INDEX['right_hand'], 0] += 0.1
    assert decide(obs) == ['b', 'c', 'd']


def leading(lead, turned_views='bcd', lean=0.0):
    """Four views of the body with its hands hanging, its trunk leaning
    ``lean`` m forward at the neck, the head on the trunk's line but
    ``lead`` m in front of it; ``turned_views`` take the back for the
    front."""
    obs = views('abcd', turned_views=turned_views, forward=0.0)
    for o in obs:
        neck = o.positions[INDEX['neck']]
        neck[0] += lean
        trunk = neck - o.positions[[INDEX['left_hip'],
                                    INDEX['right_hip']]].mean(axis=0)
        o.positions[INDEX['head']] = neck + 0.2 * trunk \
            / np.linalg.norm(trunk) + (lead, 0.0, 0.0)
    return obs


def test_where_the_hands_say_nothing_the_head_leads_labels_in_doubt():
    decision = views_to_turn(leading(0.08), FacingParams())
    assert decision.turn == [False, True, True, True]
    assert decision.by_head and decision.unsure and decision.front is None
    assert decide(leading(-0.08)) == ['a']
    # 4 cm ahead decides where the views disagree (split_head_margin,
    # 3 cm); a head 2 cm ahead, or on the line of a trunk leaning 0.15 m:
    # the views stand.
    assert decide(leading(0.04)) == ['b', 'c', 'd']
    for obs in (leading(0.02), leading(0.0, lean=0.15)):
        decision = views_to_turn(obs, FacingParams())
        assert not any(decision.turn) and not decision.by_head
        assert decision.unsure
    assert decide(leading(0.08, lean=0.15)) == ['b', 'c', 'd']
    assert decide(leading(0.08),
                  FacingParams(split_head_margin=math.inf)) == []
    assert decide(leading(0.08), FacingParams(head_margin=math.inf)) \
        == ['b', 'c', 'd']
    # Views that all agree on a front the head leads away from by 4 cm
    # stand sure (head_margin, 5 cm); by 8 cm they are in doubt.
    agree = views_to_turn(leading(-0.04, turned_views=''), FacingParams())
    assert not any(agree.turn) and not agree.unsure
    assert views_to_turn(leading(-0.08, turned_views=''),
                         FacingParams()).unsure
    # The hands, where they say something, and a held front come first.
    reach = leading(-0.08)
    for o in reach:
        for hand in HANDS:
            o.positions[INDEX[hand], 0] += 0.3
    assert decide(reach) == ['b', 'c', 'd']
    assert decide(leading(-0.08), held=np.array([1.0, 0.0, 0.0])) \
        == ['b', 'c', 'd']


def kneeling(obs, bend=0.2):
    """``obs`` with both knees bent ``bend`` m forward (+x) off their
    hip-foot lines."""
    for o in obs:
        for knee in ('left_knee', 'right_knee'):
            o.positions[INDEX[knee], 0] += bend
    return obs


def test_views_that_agree_on_a_front_the_head_leads_away_from():
    # Every view takes the same front; a head that leads the trunk's line
    # to their back puts their labels in doubt.
    agreed = views_to_turn(leading(0.08, turned_views=''), FacingParams())
    assert agreed.turn == [False] * 4 and not agreed.unsure
    for lead in (-0.03, 0.0):
        assert not views_to_turn(leading(lead, turned_views=''),
                                 FacingParams()).unsure
    # Legs straight, the trackers had no cue to the front: the views are
    # turned to the head (the labels still in doubt).
    behind = views_to_turn(leading(-0.08, turned_views=''), FacingParams())
    assert behind.turn == [True] * 4
    assert behind.unsure and behind.by_head and behind.front is None
    assert decide(leading(0.08, turned_views='abcd')) == list('abcd')
    assert decide(leading(-0.08, turned_views='abcd')) == []
    # A knee bent 0.2 m is a cue: the views stand, their labels in doubt.
    bent = views_to_turn(kneeling(leading(-0.08, turned_views='')),
                         FacingParams())
    assert bent.turn == [False] * 4 and bent.unsure and not bent.by_head
    # Bent 0.1 m, or knee_bend 0 (never turned):
    assert decide(kneeling(leading(-0.08, turned_views=''), 0.1)) \
        == list('abcd')
    assert decide(leading(-0.08, turned_views=''),
                  FacingParams(knee_bend=0.0)) == []
    # Knees one view sees: the legs say nothing either way.
    obs = leading(-0.08, turned_views='')
    for o in obs[1:]:
        o.confidence[INDEX['left_knee']] = 0.2
    assert decide(obs) == []


def test_the_head_of_one_view_decides_nothing():
    obs = leading(0.08)
    for o in obs[1:]:
        o.positions[INDEX['head']] = np.nan
    assert decide(obs) == []
    obs = leading(0.08)
    for o in obs[1:]:
        o.confidence[INDEX['neck']] = 0.2
    assert decide(obs) == []


def test_nan_hands_and_a_view_without_hips_are_left_out():
    obs = views('abcd', turned_views='bc')
    obs[0].positions[INDEX['left_hand']] = np.nan
    obs[3].positions[INDEX['left_hip']] = np.nan
    assert decide(obs) == ['b', 'c']


def test_two_views_turned_of_four_are_counted_and_fused_nearer():
    # The salsa dancer's back and left views take the back for the front
    # from 2 to 4 s: half the views, which the turn rule of
    # hri_sync.fusion.arms leaves alone; the hands put them right.
    arms = ArmParams(turn_margin=math.inf)
    fusion, frames, truth = run(arms, swap=turned, swapped=('back', 'left'))
    kept, kept_frames, _ = run(arms, swap=turned, swapped=('back', 'left'),
                               facing=FacingParams(margin=math.inf))
    during = sum(1 for f in frames if 2.0 <= f.stamp < 4.0)
    for view in ('back', 'left'):
        assert 0.5 * during <= fusion.health[view].turned_to_hands <= during
        assert kept.health[view].turned_to_hands == 0
    assert fusion.health['front'].turned_to_hands == 0
    joints = [INDEX[side + '_' + j] for side in ('left', 'right')
              for j in ('shoulder', 'elbow', 'hand', 'hip', 'knee', 'foot')]
    assert hand_error(frames, truth, 2.0, 4.0, joints) \
        < 0.5 * hand_error(kept_frames, truth, 2.0, 4.0, joints)
    _, _, _, values = view_status(fusion, 'back')
    assert ('turned to the hands',
            str(fusion.health['back'].turned_to_hands)) in values


def hanging(hold, head_ahead=0.0, margin=FacingParams.split_head_margin):
    """The fusion (and its frames) of the test above, the views behind
    facing the wrong way from 2 to 5.5 s and every view's hands at the
    trunk from 3 to 5 s (they say nothing of the front there), the head
    ``head_ahead`` m further to the front there, the front the hands last
    decided held ``hold`` s, the head deciding where it leads by
    ``margin``."""
    hands = [INDEX[h] for h in HANDS]

    def at_trunk(t, p):
        if 3.0 <= t < 5.0:
            p[hands] = p[TRUNK].mean(axis=0)
            p[INDEX['head']] += head_ahead * front(p)
        return p
    fusion, frames, _ = run(ArmParams(turn_margin=math.inf), swap_to=5.5,
                            swap=turned, swapped=('back', 'left'),
                            facing=FacingParams(
                                hold=hold, split_head_margin=margin),
                            alter=at_trunk)
    return fusion, frames


def test_where_the_hands_hang_unheld_the_head_turns_the_views_behind():
    during = 60     # instants in 3-5 s
    fusion, _ = hanging(0.0, head_ahead=0.08)
    off, _ = hanging(0.0, head_ahead=0.08, margin=math.inf)
    for view in ('back', 'left'):
        assert fusion.health[view].turned_to_head >= 0.9 * during
        assert off.health[view].turned_to_head == 0
    assert fusion.health['front'].turned_to_head == 0
    _, _, _, values = view_status(fusion, 'back')
    assert ('turned to the head',
            str(fusion.health['back'].turned_to_head)) in values
    # The salsa dancer's own head (about 0.03 m ahead) turns the views
    # behind at some of those instants, never the one in front; at a 5 cm
    # margin none.
    own = hanging(0.0)[0].health
    assert own['back'].turned_to_head > 0 and own['front'].turned_to_head == 0
    assert hanging(0.0, margin=0.05)[0].health['back'].turned_to_head == 0


def test_the_front_the_hands_last_decided_is_held_where_they_say_nothing():
    during = 60     # instants in 3-5 s
    held, held_frames = hanging(FacingParams().hold)
    lapsed, _ = hanging(1.0)
    unheld, frames = hanging(0.0)

    def turned_to_hands(fusion):
        return fusion.health['back'].turned_to_hands \
            - unheld.health['back'].turned_to_hands
    assert turned_to_hands(held) >= 0.9 * during
    # Held 1 s, the front lapses halfway through.
    assert 0.3 * during <= turned_to_hands(lapsed) <= 0.7 * during
    # Held or not, the views' labels are in doubt there (the hands said
    # the front before, not now): each shoulder's bound takes in the
    # other shoulder.
    left, right = INDEX['left_shoulder'], INDEX['right_shoulder']

    def bodies(frames, start=3.1, end=5.0):
        return [f.people[0].body for f in frames
                if start <= f.stamp < end and f.people]

    def apart(b):
        return np.linalg.norm(b.positions[left] - b.positions[right])
    for doubt in (bodies(frames), bodies(held_frames)):
        assert len(doubt) >= 50
        assert all(b.bound[left] >= apart(b) and b.bound[right] >= apart(b)
                   for b in doubt)
    # Before, the views agree (and the head leads their way): sure.
    sure = bodies(held_frames, 0.5, 2.0)
    assert len(sure) >= 30
    assert sum(b.bound[left] < apart(b) for b in sure) >= 0.8 * len(sure)
    # /diagnostics says which.

    def sides(t0, t1):
        return {dict(people_status(held, f)[3])['person %d sides'
                                                % f.people[0].person]
                for f in held_frames if t0 <= f.stamp < t1 and f.people}
    assert sides(3.1, 5.0) == {'in doubt'}
    assert sides(0.5, 2.0) == {'sure'}


def test_views_that_all_took_the_back_for_the_front_are_turned_to_the_head():
    # From 2 to 5.5 s every view's tracker takes the dancer's back for
    # the front; from 3 to 5 s the hands hang, the knees straighten and
    # the head leads 0.08 m to the true front: the four views are turned.
    side = BODY_LEFT + BODY_RIGHT

    def straight(t, p):
        if 3.0 <= t < 5.0:
            p[[INDEX[h] for h in HANDS]] = p[TRUNK].mean(axis=0)
            for s in ('left', 'right'):
                hip, foot = p[INDEX[s + '_hip']], p[INDEX[s + '_foot']]
                p[INDEX[s + '_knee']] = (hip + foot) / 2
            p[INDEX['head']] += 0.08 * front(p)
        return p

    def fused(knee_bend):
        return run(ArmParams(turn_margin=math.inf), swap_to=5.5,
                   swap=turned, swapped=tuple(POSES), alter=straight,
                   facing=FacingParams(hold=0.0, knee_bend=knee_bend))
    fusion, frames, truth = fused(FacingParams.knee_bend)
    never, never_frames, _ = fused(0.0)
    during = sum(1 for f in frames if 3.0 <= f.stamp < 5.0)
    for view in POSES:
        assert fusion.health[view].turned_to_head >= 0.9 * during
        assert never.health[view].turned_to_head == 0
    assert hand_error(frames, truth, 3.2, 5.0, side) \
        < 0.5 * hand_error(never_frames, truth, 3.2, 5.0, side)
