"""hri_sync.people.participant: the participant zone and its choices."""
from types import SimpleNamespace

import numpy as np
import pytest

from hri_sync.dance_off.expressiveness import SkeletonExpressiveness
from hri_sync.dance_off.joints import NUM_JOINTS
from hri_sync.people.participant import (BYSTANDER, PARTICIPANT,
                                         ParticipantSelector, Zone,
                                         summary_text)
from hri_sync.data_process.processors import Frame

ZONE = Zone(-0.5, 0.5, 1.5, 3.0)


def person(x, z, jitter=0.0, rng=None):
    """A standing person's 15 joints around torso (x, 1.0, z)."""
    p = np.tile([x, 1.0, z], (NUM_JOINTS, 1)) + np.linspace(
        -0.3, 0.3, NUM_JOINTS)[:, None] * [0.5, 2.0, 0.1]
    if jitter:
        p = p + rng.normal(0.0, jitter, p.shape)
    return p


def test_zone_parse_and_contains():
    assert Zone.parse('') is None and Zone.parse([]) is None
    assert Zone.parse('[-0.5, 0.5, 1.5, 3.0]') == ZONE
    assert Zone.parse([-0.5, 0.5, 1.5, 3]) == ZONE
    assert ZONE.contains((0.0, 5.0, 2.0))
    assert not ZONE.contains((0.6, 1.0, 2.0))
    assert not ZONE.contains((np.nan, 1.0, 2.0))
    for bad in ('1 2 3', 'a b c d', [1, 0, 2, 3], [0, 1, 2, float('nan')]):
        with pytest.raises(ValueError):
            Zone.parse(bad)


def test_bystander_outside_never_scored():
    sel = ParticipantSelector(ZONE, start=0.0, end=2.0)
    for k in range(40):
        t = k * 0.05
        assert sel.offer(t, 1, person(0.0, 2.0)) == PARTICIPANT
        assert sel.offer(t + 0.001, 2, person(1.5, 2.0)) == BYSTANDER
    s = sel.summary()
    assert s['participant'] == '1' and s['bystander_frames'] == 40
    assert (s['participant_lost'], s['participant_switched'],
            s['zone_intruders']) == (0, 0, 0)
    assert s['participant_absent_s'] == 0.0


def test_intruder_is_reported_not_scored():
    sel = ParticipantSelector(ZONE, start=0.0, end=2.0)
    for k in range(40):
        t = k * 0.05
        sel.offer(t, 1, person(0.0, 2.0))
        x = 1.5 if k < 20 else 0.4          # steps into the zone at 1 s
        assert sel.offer(t + 0.001, 2, person(x, 2.6)) == BYSTANDER
    s = sel.summary()
    assert s['zone_intruders'] == 1 and s['participant'] == '1'
    assert 'intruder 2' in s['participant_events']
    assert '1.001 s intruder' in s['participant_events']


def test_new_id_after_loss_continues_the_participant():
    sel = ParticipantSelector(ZONE, lost_after=0.5, start=0.0, end=4.0)
    for k in range(20):                      # id 1 for 1 s
        sel.offer(k * 0.05, 1, person(0.0, 2.0))
    for k in range(20):                      # bystander only, 1 s
        sel.offer(1.0 + k * 0.05, 3, person(2.0, 2.0))
    for k in range(40):                      # id 4 in the zone, 2 s
        assert sel.offer(2.0 + k * 0.05, 4, person(0.2, 2.5)) == PARTICIPANT
    s = sel.summary()
    assert s['participant'] == '1,4'
    assert (s['participant_lost'], s['participant_switched']) == (1, 1)
    # present 0..1.45 (lost_after after its last frame) and 2..4
    assert s['participant_absent_s'] == pytest.approx(0.55, abs=1e-6)
    assert 'lost 1' in summary_text(s) and 'switched 1' in summary_text(s)


def test_id_jump_in_place_switches_without_loss():
    sel = ParticipantSelector(ZONE, start=0.0, end=2.0)
    for k in range(40):
        user = 1 if k < 20 else 7
        assert sel.offer(k * 0.05, user, person(0.0, 2.0)) == PARTICIPANT
    s = sel.summary()
    assert (s['participant_lost'], s['participant_switched']) == (0, 1)
    assert s['participant_absent_s'] == 0.0


def test_leaving_the_zone_is_a_loss_and_absent_window():
    sel = ParticipantSelector(ZONE, start=0.0, end=2.0)
    for k in range(40):
        x = 0.0 if k < 10 else 1.0
        sel.offer(k * 0.05, 1, person(x, 2.0))
    s = sel.summary()
    assert s['participant_lost'] == 1 and 'left_zone' in \
        s['participant_events']
    empty = ParticipantSelector(ZONE, start=0.0, end=2.0)
    for k in range(40):
        empty.offer(k * 0.05, 2, person(2.0, 2.0))
    s = empty.summary()
    assert s['participant'] == 'absent' and s['participant_absent_s'] == 2.0
    assert summary_text(s).startswith('participant absent')


def msg(user, pos, sources=()):
    pts = [SimpleNamespace(x=p[0], y=p[1], z=p[2]) for p in pos]
    return SimpleNamespace(positions=pts, confidence=[1.0] * NUM_JOINTS,
                           user_id=user, sources=list(sources))


def test_processor_still_participant_and_wild_bystander():
    """A still participant and a wildly moving bystander: the score is
    the participant's noise only."""
    rng = np.random.default_rng(3)
    frames = []
    for k in range(100):
        t = 10.0 + k * 0.05
        frames.append(Frame(t, msg(1, person(0.0, 2.0, 0.002, rng))))
        frames.append(Frame(t + 0.01, msg(
            2, person(1.5 + np.sin(k), 2.0, 0.3, rng))))
    zoned = SkeletonExpressiveness(participant_zone=[-0.5, 0.5, 1.5, 3.0])
    res = zoned.process(frames, 10.0, 15.0)
    assert res.value < 1.0
    assert res.frames_used == 100 and res.frames_rejected == 100
    assert res.diagnostics['bystander_frames'] == 100
    # without a zone the first one seen is chosen: the same here
    res = SkeletonExpressiveness().process(frames, 10.0, 15.0)
    assert res.diagnostics['participant'] == '1' and res.value < 1.0


def test_processor_names_the_views_of_a_fused_participant():
    """A fused body's frames carry their views (Skeleton sources): the
    result names those of the scored frames, with each one's count; a
    bystander's views are not the participant's."""
    frames = []
    for k in range(40):
        views = ['cam1', 'cam2'] + (['robot1/cam'] if k >= 30 else [])
        frames.append(Frame(k * 0.05, msg(1, person(0.0, 2.0), views)))
        frames.append(Frame(k * 0.05 + 0.01, msg(2, person(1.5, 2.0),
                                                 ['cam9'])))
    zoned = SkeletonExpressiveness(participant_zone=[-0.5, 0.5, 1.5, 3.0])
    res = zoned.process(frames, 0.0, 2.0)
    assert res.diagnostics['sources'] == 'cam1 cam2 robot1/cam'
    assert res.diagnostics['source_frames'] == \
        'cam1:40 cam2:40 robot1/cam:10'
    plain = SkeletonExpressiveness().process(
        [Frame(k * 0.05, msg(1, person(0.0, 2.0))) for k in range(20)],
        0.0, 1.0)
    assert 'sources' not in plain.diagnostics


def test_processor_absent_participant_has_no_data():
    frames = [Frame(k * 0.05, msg(2, person(2.0, 2.0))) for k in range(20)]
    res = SkeletonExpressiveness(participant_zone='-0.5 0.5 1.5 3').process(
        frames, 0.0, 1.0)
    assert res.frames_used == 0 and res.diagnostics['participant'] == \
        'absent'


def test_processor_bad_zone_param():
    with pytest.raises(ValueError):
        SkeletonExpressiveness(participant_zone=[1, 2, 3])


def test_zone_in_the_world_frame():
    # a sensor at (3, 0, 1) m looking back along -x (yaw pi): a person 2 m
    # in front of it, straight ahead, stands at world x 1, y 0
    zone = Zone.parse('0.5, 1.5, -0.5, 0.5', '3 0 1 3.14159265 0')
    assert zone.contains((0.0, 0.0, 2.0))
    # the Skeleton's x is the sensor's right: 1 m to its right is world
    # y +1 (the sensor looks along -x, so its right is +y)
    assert not zone.contains((1.0, 0.0, 2.0))
    assert Zone.parse('0.5, 1.5, 0.5, 1.5', [3, 0, 1, 3.14159265, 0]
                      ).contains((1.0, 0.0, 2.0))
    assert Zone.parse('1 2 3 4', '') == Zone(1, 2, 3, 4)
    with pytest.raises(ValueError):
        Zone.parse('1 2 3 4', '1 2 3')


def test_processor_params_recorded_for_a_recompute():
    """verify_decisions remakes the processor from a result's diagnostics."""
    proc = SkeletonExpressiveness(0.4, participant_zone='-0.5, 0.5, 1.5, 3',
                                  lost_after=0.7,
                                  zone_sensor_pose=[1, 2, 1, 0.5, 0.1])
    text = {k: str(v) for k, v in proc.result().diagnostics.items()}
    again = SkeletonExpressiveness(**SkeletonExpressiveness.params_from(text))
    assert (again.zone, again.lost_after, again.min_confidence) == (
        proc.zone, 0.7, 0.4)
    plain = SkeletonExpressiveness(**SkeletonExpressiveness.params_from({}))
    assert plain.zone is None and plain.min_confidence == 0.5
