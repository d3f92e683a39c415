"""Skeleton drawings and frame poses for rviz (hri_sync.dance_off.markers,
hri_sync.dance_off.frames)."""
import math

import numpy as np
import pytest

from hri_sync.dance_off.frames import (REP103, SENSOR, pose, quaternion,
                                       rotation, skeleton_point)
from hri_sync.dance_off.joints import INDEX, NUM_JOINTS
from hri_sync.dance_off.markers import (BONE_WIDTH, BONES, GOLD,
                                        WINNER_BONE_WIDTH, Winner,
                                        confidence_colour, draw)


def skeleton():
    positions = [(0.1 * i, 1.0 + 0.01 * i, 2.0) for i in range(NUM_JOINTS)]
    return positions, [1.0] * NUM_JOINTS


def test_bones_join_every_joint():
    assert len(BONES) == 16
    assert {j for b in BONES for j in b} == set(range(NUM_JOINTS))


def test_confidence_colours():
    assert confidence_colour(1.0) == (0.0, 1.0, 0.0, 1.0)
    assert confidence_colour(0.5) == (1.0, 1.0, 0.0, 1.0)
    assert confidence_colour(0.0) == (1.0, 0.0, 0.0, 1.0)
    assert confidence_colour(7.0) == confidence_colour(1.0)
    assert confidence_colour(float('nan')) == (0.5, 0.5, 0.5, 1.0)


def test_draw_all_joints_and_bones():
    positions, confidence = skeleton()
    confidence[INDEX['left_hand']] = 0.0
    d = draw('left', positions, confidence)
    assert len(d.points) == NUM_JOINTS and len(d.segments) == 2 * len(BONES)
    assert len(d.segment_colours) == len(d.segments)
    hand = d.points.index(skeleton_point(positions[INDEX['left_hand']]))
    assert d.point_colours[hand] == (1.0, 0.0, 0.0, 1.0)
    # The forearm takes its least confident end's colour.
    i = BONES.index((INDEX['left_elbow'], INDEX['left_hand']))
    assert d.segment_colours[2 * i] == (1.0, 0.0, 0.0, 1.0)
    assert d.label == 'left' and d.bone_width == BONE_WIDTH
    head = positions[INDEX['head']]
    assert d.label_at == pytest.approx((-head[0], head[1] + 0.35, head[2]))


def test_draw_leaves_out_unseen_joints():
    positions, confidence = skeleton()
    positions[INDEX['right_knee']] = (math.nan, 0.0, 0.0)
    d = draw('right', positions, confidence)
    assert len(d.points) == NUM_JOINTS - 1
    assert len(d.segments) == 2 * (len(BONES) - 2)


def test_draw_winner_and_bad_input():
    positions, confidence = skeleton()
    d = draw('right', positions, confidence, winner=True)
    assert d.label == 'right: WINNER' and d.label_colour == GOLD
    assert d.bone_width == WINNER_BONE_WIDTH
    with pytest.raises(ValueError, match='15 joints'):
        draw('right', positions[:3], confidence)


def test_winner_follows_decisions_and_rounds():
    w = Winner()
    w.on_decision('winner', 2, ['left', 'right'])
    assert w.client == 'right'
    w.on_capture()
    assert w.client == ''
    w.on_decision('tie', 0, ['left', 'right'])
    assert w.client == ''
    w.on_decision('winner', 3, ['left', 'right'])  # malformed: no winner
    assert w.client == ''


def test_sensor_frame_axes():
    # A sensor facing world +x: its forward (z) is world x, its up (y) is
    # world z, its tf x (its left) is world y; a Skeleton point on the
    # sensor's right lands on world -y.
    r = rotation(0.0, 0.0, SENSOR)
    assert np.linalg.det(r) == pytest.approx(1)
    assert r @ [0, 0, 1] == pytest.approx([1, 0, 0])
    assert r @ [0, 1, 0] == pytest.approx([0, 0, 1])
    assert r @ skeleton_point((1, 0, 0)) == pytest.approx([0, -1, 0])
    # Facing world +y, tilted 30 deg down: forward points down-left.
    r = rotation(math.pi / 2, math.radians(30), SENSOR)
    assert r @ [0, 0, 1] == pytest.approx([0, math.cos(math.radians(30)),
                                           -0.5])


def test_quaternions_match_rotations():
    rng = np.random.default_rng(3)
    for _ in range(200):
        yaw, pitch = rng.uniform(-math.pi, math.pi, 2)
        for kind in (SENSOR, REP103):
            r = rotation(yaw, pitch, kind)
            x, y, z, w = quaternion(r)
            assert w >= 0 and x * x + y * y + z * z + w * w \
                == pytest.approx(1)
            back = np.array([
                [1 - 2 * (y * y + z * z), 2 * (x * y - z * w),
                 2 * (x * z + y * w)],
                [2 * (x * y + z * w), 1 - 2 * (x * x + z * z),
                 2 * (y * z - x * w)],
                [2 * (x * z - y * w), 2 * (y * z + x * w),
                 1 - 2 * (x * x + y * y)]])
            assert back == pytest.approx(r, abs=1e-9)
    assert quaternion(rotation(math.pi, 0.0)) == pytest.approx((0, 0, 1, 0))


def test_pose_checks_its_input():
    assert pose(1, 2, 3, 0.0) == ((1, 2, 3), pytest.approx((0, 0, 0, 1)))
    with pytest.raises(ValueError, match='finite'):
        pose(1, 2, math.nan, 0.0)
    with pytest.raises(ValueError, match='convention'):
        rotation(0.0, 0.0, 'optical')
