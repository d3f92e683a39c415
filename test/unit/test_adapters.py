"""hri_sync.people.adapters: other trackers' skeletons, and bad input."""
import numpy as np
import pytest

from hri_sync.dance_off.joints import INDEX, NUM_JOINTS
from hri_sync.people.adapters import (AzureKinectMarkers, OpenniTf,
                                      Rep155Tf, azure_markers,
                                      openni_transforms, split_link)
from hri_sync.people.joint_maps import (KINECT_V2, FROM_KINECT_V2,
                                        from_skeleton_frame, select,
                                        to_skeleton_frame)
from hri_sync.people.rep155 import TrackedBodies, body_transforms

RNG = np.random.default_rng(5)


def pose(x=0.0, z=2.5):
    """A plausible standing pose facing the sensor (Skeleton frame)."""
    p = np.zeros((NUM_JOINTS, 3))
    rows = {'head': (0, 0.7), 'neck': (0, 0.5), 'torso': (0, 0.25),
            'left_shoulder': (0.2, 0.5), 'right_shoulder': (-0.2, 0.5),
            'left_elbow': (0.3, 0.25), 'right_elbow': (-0.3, 0.25),
            'left_hand': (0.35, 0.0), 'right_hand': (-0.35, 0.0),
            'left_hip': (0.1, 0.0), 'right_hip': (-0.1, 0.0),
            'left_knee': (0.1, -0.45), 'right_knee': (-0.1, -0.45),
            'left_foot': (0.1, -0.9), 'right_foot': (-0.1, -0.9)}
    for name, (dx, y) in rows.items():
        p[INDEX[name]] = (x + dx, y, z)
    return p + RNG.normal(0, 0.01, p.shape)


def test_conventions_round_trip_and_axes():
    p = RNG.normal(size=(4, 3))
    for c in ('optical', 'rep103', 'kinect'):
        assert np.allclose(to_skeleton_frame(from_skeleton_frame(p, c), c), p)
    # openni_depth_frame: x forward (depth), y left, z up
    assert np.allclose(to_skeleton_frame([3.0, 0.5, 1.0], 'rep103'),
                       [-0.5, 1.0, 3.0])
    assert np.allclose(to_skeleton_frame([0.5, 1.0, 3.0], 'optical'),
                       [0.5, -1.0, 3.0])
    with pytest.raises(ValueError):
        to_skeleton_frame(p, 'enu')


def test_kinect_v2_map():
    pts = np.arange(25 * 3, dtype=float).reshape(25, 3)
    out = select(pts, KINECT_V2, FROM_KINECT_V2)
    assert np.allclose(out[INDEX['torso']], pts[KINECT_V2.index('SpineMid')])
    assert np.allclose(out[INDEX['right_foot']],
                       pts[KINECT_V2.index('FootRight')])


def test_openni_frames_one_transform_at_a_time():
    a = OpenniTf()
    p = pose()
    out = []
    for k, (child, t) in enumerate(openni_transforms(3, p)):
        out += a.add('openni_depth_frame', child, 10.0 + k * 1e-5, t,
                     10.001)
    (b,) = out
    assert b.user_id == 3 and b.stamp == 10.0
    assert np.allclose(b.positions, p) and (b.confidence == 1).all()
    # other frames of the tf tree are not skeletons, counted apart
    assert a.add('map', 'base_link', 10.0, (0, 0, 0), 10.0) == []
    assert a.counts['other_frames'] == 1 and a.frames == 1


def test_openni_bad_input_is_counted():
    a = OpenniTf(min_joints=15)
    p = pose()
    ts = openni_transforms(1, p)
    for child, t in ts[:12]:                # three joints missing
        assert a.add('openni_depth_frame', child, 1.0, t, 1.0) == []
    assert a.poll(1.005) == []              # within the window: waits
    assert a.poll(1.05) == [] and a.counts['missing_joints'] == 1
    for child, t in ts:                     # another sensor's frame
        a.add('camera_depth_frame', child, 2.0, t, 2.0)
    assert a.counts['wrong_frame'] == 1
    assert a.add('openni_depth_frame', 'head_x', 3.0, (1, 0, 0), 3.0) == []
    assert a.add('openni_depth_frame', 'head_0', 3.0, (1, 0, 0), 3.0) == []
    assert a.counts['bad_id'] == 2
    far = p.copy()
    far[0] = (0, 0, 500.0)
    for child, t in openni_transforms(1, far):
        a.add('openni_depth_frame', child, 4.0, t, 4.0)
    assert a.counts['out_of_range'] == 1
    # with min_joints 10 the partial frame passes, NaN where missing
    b = OpenniTf(min_joints=10)
    for child, t in ts[:12]:
        b.add('openni_depth_frame', child, 1.0, t, 1.0)
    (body,) = b.poll(1.1)
    assert np.isnan(body.positions[12:]).all()
    assert (body.confidence[12:] == 0).all()
    assert b.counts['joints_missing'] == 3


def test_openni_repeated_joint_closes_the_frame():
    a = OpenniTf(min_joints=1)
    ts = openni_transforms(1, pose())
    a.add('openni_depth_frame', ts[0][0], 1.0, ts[0][1], 1.0)
    out = a.add('openni_depth_frame', ts[0][0], 1.033, ts[0][1], 1.033)
    assert len(out) == 1 and out[0].stamp == 1.0


def test_id_jumps_are_counted():
    a = OpenniTf()
    p = pose()
    for user, t0 in ((1, 1.0), (2, 1.033)):
        for child, t in openni_transforms(user, p):
            a.add('openni_depth_frame', child, t0, t, t0)
    assert a.counts['id_jumps'] == 1 and a.frames == 2


def test_id_jumps_rejected_while_the_old_id_lives():
    """reject_jumps: a second id on the same person is rejected while the
    first is still tracked; once the first is gone it is the person."""
    a = OpenniTf(reject_jumps=True)
    p = pose()
    sent = {1: 0, 2: 0}

    def frame(user, t0):
        out = []
        for child, t in openni_transforms(user, p):
            out += a.add('openni_depth_frame', child, t0, t, t0)
        sent[user] += len(out)
    for k in range(10):                   # both ids, 0.3 s
        frame(1, 1.0 + k * 0.033)
        frame(2, 1.001 + k * 0.033)
    for k in range(10):                   # id 1 lost: id 2 goes on
        frame(2, 1.5 + k * 0.033)
    assert sent == {1: 10, 2: 10}
    assert a.counts['id_jump'] == 10 and a.counts['id_jumps'] == 1


def markers(body, p, stamp=5.0, frame='depth_camera_link'):
    return [(i, frame, stamp, t, 0) for i, t in azure_markers(body, p)]


def test_azure_markers():
    a = AzureKinectMarkers()
    p, q = pose(-0.8), pose(0.8)
    out = a.add(markers(0, p) + markers(2, q))
    assert [b.user_id for b in out] == [1, 3]       # body id + 1
    assert np.allclose(out[0].positions, p) and np.allclose(
        out[1].positions, q)
    assert out[0].stamp == 5.0


def test_azure_bad_input():
    a = AzureKinectMarkers()
    p = pose()
    assert a.add(markers(0, p, frame='rgb_camera_link')) == []
    assert a.counts['wrong_frame'] == 1
    m = markers(1, p)
    m[3] = (1 * 100 + 40, 'depth_camera_link', 5.0, (0, 0, 1), 0)
    assert a.add(m) == [] and a.counts['bad_id'] == 1
    m = markers(1, p)
    m[5] = m[5][:2] + (5.1,) + m[5][3:]
    assert a.add(m) == [] and a.counts['mixed_stamps'] == 1
    m = [x for x in markers(1, p) if x[0] % 100 != 26]   # no HEAD
    assert a.add(m) == [] and a.counts['missing_joints'] == 1
    assert a.add([(100, 'depth_camera_link', 5.0, (0, 0, 1), 3)]) == []
    assert a.counts['deleted_markers'] == 1


def rep155_msgs(body_id, p, frame='camera_link'):
    return [((parent or frame), child, t, q)
            for parent, child, t, q in body_transforms(body_id, p)]


def test_rep155_round_trip():
    assert split_link('l_elbow_abcde') == ('l_elbow', 'abcde')
    assert split_link('l_y_shoulder_ab_c') == ('l_y_shoulder', 'ab_c')
    assert split_link('camera_link') is None
    # hri_sync's <client>_sensor tf frames: x left, y up, z forward
    a = Rep155Tf('camera_link', convention='kinect')
    p = pose(0.3, 2.0)
    out = []
    for parent, child, t, q in rep155_msgs('kqxzv', p):
        out += a.add(parent, child, 7.0, t, q, 7.0)
    assert out == []
    (b,) = a.poll(7.1)
    assert a.ids == {'kqxzv': 1} and b.user_id == 1
    expect = p.copy()
    expect[INDEX['torso']] = (p[INDEX['neck']] + (p[INDEX['left_hip']]
                              + p[INDEX['right_hip']]) / 2) / 2
    assert np.allclose(b.positions, expect, atol=1e-9)


def test_rep155_next_stamp_closes_and_bad_input():
    a = Rep155Tf('camera_link')
    p = pose()
    for parent, child, t, q in rep155_msgs('b1', p):
        a.add(parent, child, 7.0, t, q, 7.0)
    parent, child, t, q = rep155_msgs('b1', p)[3]
    (b,) = a.add(parent, child, 7.033, t, q, 7.033)
    assert b.stamp == 7.0
    w = Rep155Tf('camera_link')
    for parent, child, t, q in rep155_msgs('b2', p, frame='other_camera'):
        w.add(parent, child, 7.0, t, q, 7.0)
    assert w.poll(8.0) == [] and w.counts['wrong_frame'] == 1
    m = Rep155Tf('camera_link')
    for parent, child, t, q in rep155_msgs('b3', p)[:5]:
        m.add(parent, child, 7.0, t, q, 7.0)
    assert m.poll(8.0) == [] and m.counts['missing_joints'] == 1


def test_tracked_bodies_are_forgotten_after_a_while():
    bodies = TrackedBodies(0.5)
    assert bodies.tracked(0.0) == ([], None)
    bodies.saw('b2', 1.0, 10.0)
    bodies.saw('a1', 1.2, 9.0)
    assert bodies.tracked(1.4) == (['a1', 'b2'], 10.0)
    assert bodies.tracked(1.6) == (['a1'], 9.0)
    assert bodies.tracked(1.8) == ([], None)


def test_fuzzed_input_never_raises():
    """Random frames, ids, stamps and coordinates (NaN, inf, huge): every
    adapter counts or passes them, none raises (seeded)."""
    rng = np.random.default_rng(20)
    names = ['head_1', 'neck_2', 'torso_x', 'left_hand_0', 'right_foot_77',
             'body_ab', 'l_elbow_ab', 'torso_ab', 'camera', '', '_', 'head_']
    frames = ['openni_depth_frame', 'camera_link', 'depth_camera_link', '',
              'body_ab', 'l_p_shoulder_ab']
    values = [0.0, 1.0, -3.0, np.nan, np.inf, -np.inf, 1e300]
    a, b, c = OpenniTf(min_joints=3), AzureKinectMarkers(min_joints=3), \
        Rep155Tf('camera_link', min_joints=3)
    for k in range(3000):
        t = float(rng.choice([k * 0.01, 0.0, -1.0, np.nan, 1e12]))
        xyz = tuple(float(v) for v in rng.choice(values, 3))
        q = tuple(float(v) for v in rng.choice(values, 4))
        parent, child = rng.choice(frames), rng.choice(names)
        a.add(parent, child, t, xyz, k * 0.01)
        c.add(parent, child, t, xyz, q, k * 0.01, static=bool(k % 7 == 0))
        b.add([(int(rng.integers(-200, 3300)), rng.choice(frames), t, xyz,
                int(rng.integers(0, 4))) for _ in range(rng.integers(0, 40))])
        if k % 50 == 0:
            a.poll(k * 0.01)
            c.poll(k * 0.01)
    for adapter in (a, b, c):
        assert sum(adapter.counts.values()) > 0
