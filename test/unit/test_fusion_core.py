"""hri_sync.fusion: frames, alignment, association, fusion, calibration."""
import math

import numpy as np
import pytest

from hri_sync.dance_off.joints import INDEX, NUM_JOINTS
from hri_sync.fusion.align import Sample, Track
from hri_sync.fusion.associate import Associator, body_distance
from hri_sync.fusion.calibration import Residuals, refine_pose, shared_points
from hri_sync.fusion.facing import back_view
from hri_sync.fusion.frames import SensorPose, facing, parse_pose
from hri_sync.fusion.fuse import FuseParams, Observation, fuse
from hri_sync.fusion.pipeline import Fusion, FusionParams
from hri_sync.fusion.profile import (ARMS, BODY_TURN, Profile, back_growth,
                                     confidence_power, fit_profile, rays,
                                     sides_as_truth)
from hri_sync.fusion.report import people_status, view_named, view_status
from hri_sync.fusion.views import Deafness
from hri_sync.people.rep155 import body_axes
from test_fusion_wrong_pose import POSES, run

RNG = np.random.default_rng(36)


def body(x=0.0, y=0.0):
    """A standing body in world (REP 103, floor z = 0) at (x, y)."""
    p = np.zeros((NUM_JOINTS, 3))
    rows = {'head': (0, 1.6), 'neck': (0, 1.4), 'torso': (0, 1.2),
            'left_shoulder': (0.2, 1.4), 'right_shoulder': (-0.2, 1.4),
            'left_elbow': (0.3, 1.15), 'right_elbow': (-0.3, 1.15),
            'left_hand': (0.35, 0.9), 'right_hand': (-0.35, 0.9),
            'left_hip': (0.1, 0.9), 'right_hip': (-0.1, 0.9),
            'left_knee': (0.1, 0.45), 'right_knee': (-0.1, 0.45),
            'left_foot': (0.1, 0.05), 'right_foot': (-0.1, 0.05)}
    for name, (dy, z) in rows.items():
        p[INDEX[name]] = (x, y + dy, z)
    return p


def fresh(positions, k):
    """A sensor's k-th reading of ``positions``: 1 um apart from the one
    before (a skeleton repeated joint for joint is no new measurement)."""
    return positions + 1e-6 * k


def test_pose_round_trip_and_axes():
    pose = facing(3.0, 0.0, 1.0)
    # A point 2 m straight ahead of the sensor, 0.5 m to its right and
    # 0.2 m up (Skeleton frame) is 1 m from the origin towards the sensor,
    # 0.5 m towards +y (the sensor faces -x, its right is +y), 1.2 m up.
    assert np.allclose(pose.to_world([0.5, 0.2, 2.0]), [1.0, 0.5, 1.2])
    points = RNG.normal(size=(20, 3))
    assert np.allclose(pose.to_world(pose.from_world(points)), points)


def test_parse_pose():
    assert parse_pose('1 2 1.0 0.5') == SensorPose(1, 2, 1.0, 0.5)
    assert parse_pose([1, 2, 1, 0.5, 0.1]).pitch == 0.1
    for bad in ('1 2 3', '1 2 3 nan', 'a b c d'):
        with pytest.raises(ValueError):
            parse_pose(bad)


def sample(t, positions, conf=1.0, u=0.001):
    return Sample(t, np.array(positions, float), np.full(len(positions),
                                                         conf), u)


def test_track_interpolates_between_samples_not_to_a_period():
    track = Track()
    track.add(sample(1.000, body(0.0)))
    track.add(sample(1.033, body(0.33)))
    a = track.at(1.010)
    assert a.positions[0, 0] == pytest.approx(0.1)
    assert a.speed[0] == pytest.approx(10.0)
    assert a.newest == 1.033
    assert track.at(0.99) is None
    assert track.at(1.05) is None
    assert track.at(1.05, max_extrapolation=0.02).positions[0, 0] \
        == pytest.approx(0.5)


def test_track_gaps_missing_joints_and_repeats():
    track = Track(max_gap=0.1)
    p = body()
    p[3] = np.nan
    track.add(sample(0.0, body()))
    assert not track.add(sample(0.0, body()))
    track.add(sample(0.05, p))
    a = track.at(0.02)
    assert np.isnan(a.positions[3]).all() and a.confidence[3] == 0
    track.add(sample(0.5, body()))
    assert track.at(0.3) is None


def test_association_one_view_person_two_close_people_stable_ids():
    assoc = Associator()
    ids = assoc.assign(0.0, {('a', 1): body(0, 0), ('b', 7): body(0.05, 0),
                             ('a', 2): body(0, 0.45)})
    assert ids[('a', 1)] == ids[('b', 7)] != ids[('a', 2)]
    for k in range(1, 60):
        t = k / 30
        bodies = {('a', 1): body(0, 0.004 * k), ('a', 2): body(0, 0.45)}
        if k < 30:
            bodies[('b', 7)] = body(0.05, 0.004 * k)
        now = assoc.assign(t, bodies)
        for key, pid in now.items():
            assoc.update(pid, bodies[key], t)
            assert pid == ids[key]
    assert assoc.switches == 0
    assert len(assoc.persons) == 2


def test_association_a_new_user_placed_too_low_joins_its_person():
    # A view's tracker has just found someone half hidden: its skeleton
    # stands where the person stands but 0.6 m too low. It is the same
    # person (people are told apart along the floor), not a second one;
    # someone 0.6 m away along the floor is.
    assoc = Associator()
    assoc.assign(0.0, {('a', 1): body(0, 0)})
    low = body(0.1, 0)
    low[:, 2] -= 0.6
    ids = assoc.assign(1 / 30, {('a', 1): body(0, 0), ('b', 5): low,
                                ('c', 2): body(0, 0.6)})
    assert ids[('b', 5)] == ids[('a', 1)] != ids[('c', 2)]
    assert len(assoc.persons) == 2


def test_association_a_user_its_tracker_gives_to_someone_else_moves():
    # Two people 0.7 m apart, seen by views a and b. View b's tracker loses
    # its user 3 (on the first person) and finds it again on the second:
    # the key leaves the first person (whose body the other view holds)
    # for the second at once, and neither person gets the other's joints.
    assoc = Associator()
    first = assoc.assign(0.0, {('a', 1): body(0, 0), ('a', 2): body(0, 0.7),
                               ('b', 3): body(0.05, 0)})
    for key, pid in first.items():
        assoc.update(pid, body(0, 0.7 * (key == ('a', 2))), 0.0)
    ids = assoc.assign(1 / 30, {('a', 1): body(0, 0),
                                ('a', 2): body(0, 0.7),
                                ('b', 3): body(0.05, 0.72)})
    assert ids[('b', 3)] == first[('a', 2)] != first[('b', 3)]
    assert assoc.switches == 1 and assoc.jumps == 0


def test_association_gates_grow_while_a_person_is_unseen():
    # A person one view sees walks on (1.5 m/s) through a 0.5 s gap in
    # that view's tracking: the key that comes back 0.8 m on is theirs.
    assoc = Associator()
    pid = assoc.assign(0.0, {('a', 1): body(0, 0)})[('a', 1)]
    assoc.update(pid, body(0, 0), 0.0)
    assert assoc.assign(0.5, {('a', 1): body(0.8, 0)}) == {('a', 1): pid}
    assoc.update(pid, body(0.8, 0), 0.5)
    assert assoc.assign(0.55, {('a', 1): body(1.7, 0)}) == {}
    assert assoc.jumps == 1


def test_association_merges_duplicates_and_forgets():
    assoc = Associator(merge_after=0.2, forget_after=0.5)
    ids = {}
    for k in range(30):
        t = k / 30
        bodies = {('a', 1): body(0, 0),
                  ('b', 1): body(0, max(0.6 - 0.05 * k, 0.05))}
        ids = assoc.assign(t, bodies)
        if k == 0:
            first = dict(ids)
        for key, pid in ids.items():
            assoc.update(pid, bodies[key], t)
    assert first[('a', 1)] != first[('b', 1)]
    assert ids[('b', 1)] == ids[('a', 1)] == first[('a', 1)]
    assert list(assoc.persons) == [first[('a', 1)]]
    assoc.assign(2.0, {})
    assert not assoc.persons


def test_a_tracker_user_given_again_soon_keeps_its_person():
    # A view gives no body for 2 s (its tracker lost the user, or its
    # node starved) and then the same user near where it was: the same
    # person. Another user of it there, or the same one 3.5 s later, is
    # someone new.
    for key, back, same in ((('a', 1), 2.0, True), (('a', 2), 2.0, False),
                            (('a', 1), 3.5, False)):
        assoc = Associator()
        pid = assoc.assign(0.0, {('a', 1): body(0, 0)})[('a', 1)]
        assoc.update(pid, body(0, 0), 0.0)
        for k in range(1, int(back * 30)):     # the instants between
            assert assoc.assign(k / 30, {}) == {}
        assert not assoc.persons                # forgotten after 1 s
        again = assoc.assign(back, {key: body(0.3, 0)})[key]
        assert (again == pid) == same, (key, back)


def test_deafness_is_hearing_from_no_view_for_over_its_threshold():
    # Heard at 0-1 s every 0.1 s, then nothing until 4 s: deaf 1-4 s
    # (a silence of 1 s or less is not counted); deaf again from 4 s
    # once the silence it is in passes 1 s.
    deaf = Deafness(1.0)
    assert deaf.within(0.0, 10.0) == 0.0       # nothing heard yet
    for k in range(11):
        deaf.heard(k / 10)
    deaf.heard(1.9)
    assert deaf.within(0.0, 2.0) == 0.0
    deaf.heard(4.9)
    assert deaf.within(0.0, 4.9) == pytest.approx(3.0)
    assert deaf.within(2.5, 3.0) == pytest.approx(0.5)
    assert deaf.within(4.9, 5.5) == 0.0
    assert deaf.within(4.9, 6.5) == pytest.approx(1.6)


def test_a_fusion_that_falls_behind_keeps_its_people():
    # Two views give one person all along, but the fusion is not polled
    # for 2.5 s (its node starved on a busy machine): it skips ahead, and
    # the person its views never stopped seeing keeps the id, as does one
    # they stopped giving for 0.3 s in that time (their node starved too),
    # or for the whole 2.5 s (their trackers kept the user's id), or for
    # 3.5 s while the fusion heard from no view (no view said the person
    # had gone). The person is a new one when the views are silent for
    # 3.5 s but their trackers say each second that they track no one, or
    # when the views go on giving another person (2 m away) meanwhile.
    poses = {'a': facing(3.0, 0.0, 1.0), 'b': facing(0.0, 3.0, 1.0)}
    for unseen, heard, same in (
            (range(0), None, True), (range(60, 69), None, True),
            (range(95, 104), None, True), (range(30, 105), None, True),
            (range(30, 135), None, True),
            (range(30, 135), 'status', False),
            (range(30, 135), 'another', False)):
        clock = {'now': 0.0}
        fusion = Fusion(poses, FusionParams(), lambda: clock['now'])
        ids = []
        for k in range(180):
            t = k / 30
            clock['now'] = t + 0.05
            for view, pose in poses.items():
                if k not in unseen:             # the views see the person
                    fusion.add(view, 1, t, pose.from_world(fresh(body(), k)),
                               np.full(NUM_JOINTS, 0.9), 0.001)
                elif heard == 'status' and k % 30 == 0:
                    fusion.sensor_said(view, 1, 'not tracking: nobody')
                if heard == 'another':
                    fusion.add(view, 2, t,
                               pose.from_world(fresh(body(2.0, 0.0), k)),
                               np.full(NUM_JOINTS, 0.9), 0.001)
            if not 30 <= k < 105:               # the fusion is polled
                ids += [p.person for f in fusion.poll() for p in f.people
                        if body_distance(p.body.positions, body()) < 1.0]
        assert (set(ids) == {ids[0]}) == same, (unseen, heard, ids)


def test_the_fused_latency_is_output_time_less_the_newest_capture():
    # Each view's skeleton arrives 50 ms after its capture and the
    # fusion is polled on arrival: every body is out 50 ms after the
    # newest capture it used, as /diagnostics says.
    assert math.isnan(Fusion({}).latency())
    fusion, frames = run(1.0, {}, [lambda view, t: body()])
    assert len(frames) >= 25
    assert fusion.latency() == pytest.approx(0.05, abs=1e-9)
    values = dict(people_status(fusion, frames[-1])[3])
    assert values['latency p95 after the newest capture (ms)'] == '50.0'


def test_a_trackers_delay_is_not_counted_as_latency():
    # The profile dates each skeleton 40 ms before its capture (the
    # tracker's filter delay); its capture is still what the latency is
    # counted from, for the fused body and for each view.
    delayed = Profile(delay=0.04)
    fusion, frames = run(1.0, {}, [lambda view, t: body()],
                         profiles={v: delayed for v in POSES})
    assert len(frames) >= 20
    assert fusion.latency() == pytest.approx(0.05, abs=1e-9)
    assert all(p.newest <= f.published - 0.05 + 1e-9
               for f in frames for p in f.people)
    view = dict(view_status(fusion, sorted(POSES)[0])[3])
    assert view['latency p95 (ms)'] == '50.0'


def obs(view, positions, conf=0.9, speed=0.0, u=0.001, weight=1.0):
    return Observation(view, positions, np.full(NUM_JOINTS, conf),
                       np.full(NUM_JOINTS, speed), u, weight)


def test_fuse_weights_and_hidden_joint_from_the_other_view():
    truth = body()
    a, b = truth + 0.02, truth - 0.02
    a[INDEX['left_hand']] += 0.3
    oa, ob = obs('a', a), obs('b', b)
    oa.confidence[INDEX['left_hand']] = 0.1
    f = fuse([oa, ob], FuseParams())
    assert np.allclose(f.positions[INDEX['head']], truth[INDEX['head']])
    hand = f.positions[INDEX['left_hand']] - truth[INDEX['left_hand']]
    assert np.linalg.norm(hand) < 0.06
    assert f.confidence[INDEX['left_hand']] == pytest.approx(0.9)
    assert f.views == ['a', 'b']


def test_fuse_bound_grows_with_timing_uncertainty_times_speed():
    slow = fuse([obs('a', body(), speed=0.1)], FuseParams())
    fast = fuse([obs('a', body(), speed=3.0, u=0.01)], FuseParams())
    assert fast.bound[0] >= slow.bound[0] + 0.01 * 3.0 * 0.5
    assert slow.bound[0] == pytest.approx(2.8 * 0.05 / 0.9, rel=0.01)


def test_fuse_bound_widens_where_the_views_scatter_beyond_their_errors():
    # Two views within 1 cm of each other: the bound is the error model's
    # (2.8 * 0.0556 / sqrt 2). Two views 0.3 m apart on the head, each
    # 0.15 m from their mean where it expects 0.056 m: the scatter's
    # chi-square over its 3 degrees of freedom, 4.86, scales the error
    # model's variance. A larger scatter held from before (``inflate``)
    # scales it too.
    model = 2.8 * 0.05 / 0.9 / math.sqrt(2)
    near = fuse([obs('a', body() + 0.005), obs('b', body() - 0.005)],
                FuseParams())
    assert near.bound[INDEX['head']] == pytest.approx(model, rel=1e-6)
    assert near.scatter[INDEX['head']] < 1
    apart = [obs('a', body()), obs('b', body())]
    apart[0].positions[INDEX['head'], 0] += 0.15
    apart[1].positions[INDEX['head'], 0] -= 0.15
    wide = fuse(apart, FuseParams())
    chi2 = 2 * (0.15 / (0.05 / 0.9)) ** 2 / 3
    assert wide.scatter[INDEX['head']] == pytest.approx(chi2)
    assert wide.bound[INDEX['head']] == pytest.approx(model * math.sqrt(chi2))
    assert wide.bound[INDEX['torso']] == pytest.approx(
        near.bound[INDEX['torso']], rel=0.01)
    held = fuse([obs('a', body() + 0.005), obs('b', body() - 0.005)],
                FuseParams(), np.full(NUM_JOINTS, 4.0))
    assert held.bound[INDEX['head']] == pytest.approx(2 * model)


def test_fuse_drops_an_outlier_of_three_and_missing_joints():
    views = [obs(v, body() + RNG.normal(0, 0.01, (NUM_JOINTS, 3)))
             for v in 'abc']
    views[2].positions[INDEX['torso']] += 1.0
    for o in views:
        o.positions[INDEX['head']] = np.nan
    f = fuse(views, FuseParams())
    assert np.linalg.norm(f.positions[INDEX['torso']]
                          - body()[INDEX['torso']]) < 0.03
    assert np.isnan(f.positions[INDEX['head']]).all()
    assert f.confidence[INDEX['head']] == 0


def test_fuse_weighs_a_view_by_its_agreement_with_the_others():
    # Three views, one 0.25 m off (under the 0.3 m outlier cut): weighted
    # by agreement, the fused joint follows the two that agree; two views
    # alone, each as far from the middle, stay as they were weighted.
    truth = body()
    views = [obs(v, truth.copy()) for v in 'abc']
    views[2].positions = truth + [0.25, 0, 0]
    plain = fuse(views, FuseParams(agreement=0))
    agreed = fuse(views, FuseParams())
    assert plain.positions[0, 0] == pytest.approx(0.25 / 3)
    assert agreed.positions[0, 0] < plain.positions[0, 0] / 2
    two = [obs('a', truth), obs('b', truth + [0.2, 0, 0])]
    assert fuse(two, FuseParams()).positions[0, 0] == pytest.approx(0.1)


def test_profile_error_grows_with_falling_confidence_as_measured():
    # Errors whose size grows as confidence ** -0.5 within each joint:
    # the power is found; the profile keeps it (YAML and back) and the
    # fusion weighs by it (at confidence 0.25 a view's error is twice, not
    # four times, that at 1: a fourth of the weight, not a sixteenth).
    rng = np.random.default_rng(4)
    conf = rng.choice([0.25, 0.5, 1.0], size=(3, 400, NUM_JOINTS))
    scale = np.linspace(0.03, 0.12, NUM_JOINTS)     # joints differ
    own = rng.normal(size=(3, 400, NUM_JOINTS, 3)) \
        * (scale * conf ** -0.5)[..., None]
    assert confidence_power(own, conf) == pytest.approx(0.5, abs=0.05)
    profile = Profile(sigma=0.05, confidence_power=0.5)
    assert Profile.from_dict(profile.to_dict()).confidence_power == 0.5
    sure, unsure = obs('a', body(), conf=1.0), obs('b', body(0.1), conf=0.25)
    sure.power = unsure.power = 0.5
    f = fuse([sure, unsure], FuseParams(agreement=0))
    assert f.positions[0, 0] == pytest.approx(0.1 / 5)


def test_back_view_is_how_much_of_the_back_a_sensor_sees():
    # body() faces +x: a sensor ahead sees its front, one to its side
    # half, one behind its back; a body without hips has none.
    assert back_view(body(), (3, 0, 1)) == pytest.approx(0.0)
    assert back_view(body(), (0, 3, 1)) == pytest.approx(0.5)
    assert back_view(body(), (-3, 0, 1)) == pytest.approx(1.0)
    hipless = body()
    hipless[INDEX['left_hip']] = np.nan
    assert back_view(hipless, (3, 0, 1)) is None


def turning(frames):
    """A body turning once on the spot (frames, 15, 3) and four sensors
    around it (4, 3)."""
    turns = np.linspace(0, 2 * np.pi, frames)
    truth = np.array([body() @ np.array([[math.cos(a), math.sin(a), 0],
                                         [-math.sin(a), math.cos(a), 0],
                                         [0, 0, 1]]) for a in turns])
    return truth, np.array([(3, 0, 1), (0, 3, 1), (-3, 0, 1), (0, -3, 1)])


def test_the_arms_growth_from_behind_is_measured():
    # Arm errors (in units of their modelled sigma) 1 + 0.6 * back_view,
    # the rest 1 everywhere: b is found from four views around a body
    # turning on the spot; errors that do not grow give 0.
    rng = np.random.default_rng(7)
    truth, sensors = turning(500)
    back = np.array([[back_view(b, s) for b in truth] for s in sensors])
    norm = np.linalg.norm(rng.normal(size=(4, 500, NUM_JOINTS, 3)),
                          axis=-1) / math.sqrt(3)
    grown = norm.copy()
    grown[..., ARMS] *= (1 + 0.6 * back)[..., None]
    assert back_growth(grown, truth, sensors) == pytest.approx(0.6, abs=0.1)
    assert back_growth(norm, truth, sensors) < 0.1
    profile = Profile(back_arms=0.6)
    assert Profile.from_dict(profile.to_dict()).back_arms == 0.6


def test_the_depth_offsets_along_each_sensors_line_are_measured():
    # Views around a body turning on the spot place every joint 0.03 m
    # (the hands 0.05 m) nearer their sensor: the body-axes offsets
    # cannot hold that (it turns with the view, not the body); the depth
    # offsets do, and correcting with them puts each view's joints back.
    rng = np.random.default_rng(11)
    truth, sensors = turning(300)
    near = np.full(NUM_JOINTS, -0.03)
    near[[INDEX['left_hand'], INDEX['right_hand']]] = -0.05
    estimates = np.array([truth + near[:, None] * rays(truth, s)
                          for s in sensors]) \
        + rng.normal(0, 0.01, (4,) + truth.shape)
    profile = fit_profile(estimates, truth, 0.0, 0.0,
                          np.ones(estimates.shape[:3]), sensors)
    assert np.allclose(profile.depth, near, atol=0.003)
    assert np.abs(profile.offsets).max() < 0.005
    before = np.linalg.norm(estimates - truth, axis=-1).mean()
    after = np.linalg.norm(np.array([[profile.correct(p, s) for p in view]
                                     for view, s in zip(estimates, sensors)])
                           - truth, axis=-1).mean()
    assert after < before / 2
    assert np.array_equal(profile.correct(truth[0]), truth[0] - (
        profile.offsets @ body_axes(truth[0]).T))
    assert np.allclose(Profile.from_dict(profile.to_dict()).depth,
                       profile.depth, atol=1e-4)
    with pytest.raises(ValueError):
        Profile.from_dict({'depth': [0.0] * 14})


def test_offsets_of_views_that_took_the_back_for_the_front():
    # Every view places the head 0.08 m low; two of four take the back
    # for the front at every other frame (every left joint at the right
    # one's place). Fitted as they come, the shoulders are offset 0.1 m
    # outwards (a quarter of the samples a shoulders' width off); with
    # each view's sides put the truth's way first, the head's offset is
    # found and the rest 0.
    rng = np.random.default_rng(12)
    truth, sensors = turning(200)
    low = np.zeros(NUM_JOINTS)
    low[INDEX['head']] = -0.08
    estimates = np.array([truth + low[:, None] * np.array([0, 0, 1])
                          for _ in sensors]) \
        + rng.normal(0, 0.01, (4,) + truth.shape)
    estimates[2:, ::2] = estimates[2:, ::2][:, :, BODY_TURN]
    conf = np.ones(estimates.shape[:3])
    conf[2:, ::2, INDEX['left_hand']] = 0.5
    as_they_come = fit_profile(estimates, truth, 0.0, 0.0)
    shoulder = as_they_come.offsets[INDEX['left_shoulder']]
    assert abs(shoulder[1] - 0.1) < 0.02    # y: left
    aligned, conf, exchanged = sides_as_truth(estimates, truth, conf)
    assert exchanged == 200
    assert np.all(conf[2:, ::2, INDEX['right_hand']] == 0.5)
    assert np.all(conf[2:, ::2, INDEX['left_hand']] == 1.0)
    profile = fit_profile(aligned, truth, 0.0, 0.0)
    expected = np.zeros((NUM_JOINTS, 3))
    expected[INDEX['head'], 2] = -0.08
    assert np.allclose(profile.offsets, expected, atol=0.005)


def test_the_median_offsets_leave_a_views_gross_misses_out():
    # Every view places the hands 0.03 m nearer its sensor; the view
    # behind the body (a quarter of the view-frames) lays them on the
    # trunk, 0.25 m nearer. The mean takes 0.085 m for the hands' depth
    # offset (every view's hands then wrong but the one behind, which
    # is still 0.16 m off); the median the 0.03 m of the views that see
    # them.
    rng = np.random.default_rng(13)
    truth, sensors = turning(200)
    hands = [INDEX['left_hand'], INDEX['right_hand']]
    near = np.zeros(NUM_JOINTS)
    near[hands] = -0.03
    estimates = np.array([truth + near[:, None] * rays(truth, s)
                          for s in sensors]) \
        + rng.normal(0, 0.01, (4,) + truth.shape)
    estimates[3][:, hands] += -0.22 * rays(truth, sensors[3])[:, hands]
    conf = np.ones(estimates.shape[:3])
    mean = fit_profile(estimates, truth, 0.0, 0.0, conf, sensors)
    median = fit_profile(estimates, truth, 0.0, 0.0, conf, sensors,
                         np.nanmedian)
    assert np.allclose(mean.depth[hands], -0.085, atol=0.01)
    assert np.allclose(median.depth[hands], -0.03, atol=0.01)
    others = np.setdiff1d(np.arange(NUM_JOINTS), hands)
    assert np.allclose(median.depth[others], 0.0, atol=0.005)
    assert np.abs(median.offsets).max() < 0.01


def test_the_fusion_takes_each_views_depth_offsets_from_its_own_sensor():
    # Two views at right angles, each placing the body 0.04 m nearer its
    # sensor: fused without depth offsets the body is half that off along
    # both lines (0.028 m); with them, where it is.
    poses = {'front': facing(3.0, 0.0, 1.0), 'side': facing(0.0, 3.0, 1.0)}
    truth = body()
    for depth, off in ((0.0, 0.02 * math.sqrt(2)), (-0.04, 0.0)):
        clock = {'now': 0.0}
        profiles = {v: Profile(depth=np.full(NUM_JOINTS, depth))
                    for v in poses}
        fusion = Fusion(poses, FusionParams(), lambda: clock['now'],
                        profiles)
        frames = []
        for k in range(10):
            clock['now'] = k / 30 + 0.05
            for view, pose in poses.items():
                seen = truth - 0.04 * rays(truth, pose.translation())
                fusion.add(view, 1, k / 30, pose.from_world(fresh(seen, k)),
                           np.full(NUM_JOINTS, 0.9), 0.001)
            frames += fusion.poll()
        fused = frames[-1].people[0].body.positions
        torso = INDEX['torso']
        assert np.linalg.norm(fused[torso] - truth[torso]) == \
            pytest.approx(off, abs=0.002)


def test_a_view_behind_the_body_gives_less_of_its_arms():
    # Two views 0.1 m apart on every joint, one in front of the body and
    # one behind it: with the profile's growth from behind the fused arms
    # lean to the front view (weights 1.5 ** 2 : 1), the trunk stays
    # half way; without it both stay half way.
    poses = {'front': facing(3.0, 0.0, 1.0), 'back': facing(-3.0, 0.0, 1.0)}
    truth = body()
    for back_arms, share in ((0.5, 1.5 ** 2 / (1 + 1.5 ** 2)), (0.0, 0.5)):
        clock = {'now': 0.0}
        profiles = {v: Profile(back_arms=back_arms) for v in poses}
        fusion = Fusion(poses, FusionParams(fuse=FuseParams(agreement=0)),
                        lambda: clock['now'], profiles)
        frames = []
        for k in range(10):
            clock['now'] = k / 30 + 0.05
            for view, shift in (('front', 0.0), ('back', 0.1)):
                fusion.add(view, 1, k / 30, poses[view].from_world(
                    fresh(truth + [0, shift, 0], k)),
                    np.full(NUM_JOINTS, 0.9), 0.001)
            frames += fusion.poll()
        fused = frames[-1].people[0].body.positions
        hand, head = INDEX['left_hand'], INDEX['head']
        moved = fused[:, 1] - truth[:, 1]
        assert moved[hand] == pytest.approx(0.1 * (1 - share), abs=1e-3)
        assert moved[head] == pytest.approx(0.05, abs=1e-3)


def test_residuals_blame_the_view_that_disagrees():
    res = Residuals(min_count=10)
    for k in range(20):
        noise = [RNG.normal(0, 0.02, (NUM_JOINTS, 3)) for _ in range(3)]
        views = {'a': body() + noise[0], 'b': body() + noise[1],
                 'c': body(0.4) + noise[2]}
        res.add(k / 30, {v: (p, np.ones(NUM_JOINTS))
                         for v, p in views.items()})
    assert res.wrong() == (['c'], [])
    two = Residuals(min_count=10)
    for k in range(20):
        two.add(k / 30, {'a': (body(), np.ones(NUM_JOINTS)),
                         'b': (body(0.4), np.ones(NUM_JOINTS))})
    assert two.wrong() == ([], [('a', 'b')])


def test_refine_pose_recovers_a_wrong_pose():
    right = facing(3.0, 0.5, 1.0)
    world = np.concatenate([body(x, y) for x, y in
                            RNG.uniform(-1, 1, (30, 2))])
    seen = right.from_world(world) + RNG.normal(0, 0.01, world.shape)
    wrong = SensorPose(right.x + 0.3, right.y - 0.1, right.z,
                       right.yaw + math.radians(10))
    refined, before, after = refine_pose(wrong, seen, world)
    assert before > 0.3 and after < 0.02
    assert refined.yaw == pytest.approx(right.yaw, abs=0.01)
    assert refined.x == pytest.approx(right.x, abs=0.03)


def test_association_leaves_out_a_jump_then_lets_it_go():
    assoc = Associator(release_after=0.5)
    for k in range(30):
        t = k / 30
        far = k >= 10
        bodies = {('a', 1): body(0, 0), ('b', 1): body(2.0 if far else 0, 0)}
        ids = assoc.assign(t, bodies)
        for key, pid in ids.items():
            assoc.update(pid, bodies[key], t)
        if 10 <= k < 25:
            assert ('b', 1) not in ids
    assert assoc.jumps == 15
    assert ids[('b', 1)] != ids[('a', 1)]


def test_shared_points_refine_a_view_from_the_others():
    right = {'a': facing(3.0, 0.5, 1.0), 'b': facing(-2.0, 2.0, 1.0),
             'c': facing(0.5, -3.0, 1.0)}
    samples = {v: [] for v in right}
    phase = {'a': 0.0, 'b': 0.011, 'c': 0.023}
    for k in range(90):
        for v, pose in right.items():
            t = k / 30 + phase[v]
            world = body(math.sin(t), 0.5 * math.cos(t))
            samples[v].append((t, pose.from_world(world)
                               + RNG.normal(0, 0.01, world.shape),
                               np.full(NUM_JOINTS, 0.9)))
    sensor, world = shared_points(samples['c'], {v: samples[v]
                                                 for v in 'ab'}, right)
    assert len(sensor) > 500
    wrong = SensorPose(0.8, -3.0, 1.0, right['c'].yaw + math.radians(10))
    refined, before, after = refine_pose(wrong, sensor, world)
    assert before > 0.2 and after < 0.03
    assert refined.x == pytest.approx(0.5, abs=0.05)
    assert refined.yaw == pytest.approx(right['c'].yaw, abs=0.02)


def test_a_views_status_is_known_by_its_name_on_diagnostics():
    # diagnostic_updater puts the node's name before the status's own:
    # a reader of /diagnostics gets the view back, and only for a view's.
    fusion, _ = run(0.3, {}, [lambda view, t: body()])
    name = view_status(fusion, 'left')[0]
    assert view_named('fused/fusion: ' + name) == 'left'
    assert view_named('/lab/fusion: ' + name) == 'left'
    assert view_named('fused/fusion: people') is None
    assert view_named('fused/fusion: calibration') is None
    assert view_named('view left') is None
    assert view_named('fused/fusion: view ') is None
