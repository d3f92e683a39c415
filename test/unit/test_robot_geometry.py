"""hri_sync.robot.geometry: angle wrapping, quaternion <-> yaw, the
odometry transform to the start pose."""
import math
import random
from types import SimpleNamespace as NS

import pytest

from hri_sync.robot.geometry import (quaternion_from_yaw, relative_pose,
                                     wrap_angle, wrap_degrees,
                                     yaw_from_quaternion, yaw_of)


def test_wrap():
    assert wrap_angle(math.pi) == pytest.approx(-math.pi)
    assert wrap_angle(3 * math.pi / 2) == pytest.approx(-math.pi / 2)
    assert wrap_angle(-0.25) == -0.25
    assert wrap_degrees(190.0) == -170.0
    assert wrap_degrees(-180.0) == -180.0
    assert wrap_degrees(540.0) == -180.0


def test_quaternion_yaw_round_trip():
    rng = random.Random(9)
    for _ in range(200):
        yaw = rng.uniform(-10.0, 10.0)
        q = quaternion_from_yaw(yaw)
        assert sum(c * c for c in q) == pytest.approx(1.0)
        assert q[:2] == (0.0, 0.0)
        assert wrap_angle(yaw_from_quaternion(*q) - yaw) == \
            pytest.approx(0.0, abs=1e-9)
        assert yaw_of(NS(x=q[0], y=q[1], z=q[2], w=q[3])) == \
            yaw_from_quaternion(*q)


def test_yaw_of_known_quaternions():
    h = math.sqrt(0.5)
    assert yaw_from_quaternion(0.0, 0.0, 0.0, 1.0) == 0.0
    assert yaw_from_quaternion(0.0, 0.0, h, h) == pytest.approx(math.pi / 2)
    assert yaw_from_quaternion(0.0, 0.0, -h, h) == pytest.approx(
        -math.pi / 2)
    assert abs(yaw_from_quaternion(0.0, 0.0, 1.0, 0.0)) == pytest.approx(
        math.pi)
    # a tilted base (roll about x) keeps its heading
    r = 0.1
    assert yaw_from_quaternion(math.sin(r / 2), 0.0, 0.0,
                               math.cos(r / 2)) == pytest.approx(0.0)


def test_relative_pose():
    origin = (1.0, 2.0, math.pi / 2)                 # facing +y
    assert relative_pose(origin, *origin) == pytest.approx((0.0, 0.0, 0.0))
    assert relative_pose(origin, 1.0, 3.0, math.pi / 2 + 0.25) == \
        pytest.approx((1.0, 0.0, 0.25))              # 1 m ahead
    assert relative_pose(origin, 2.0, 2.0, 0.0) == \
        pytest.approx((0.0, -1.0, -math.pi / 2))     # 1 m to the right
    # heading wrapped across +-pi
    x, y, yaw = relative_pose((0.0, 0.0, 3.0), 0.0, 0.0, -3.0)
    assert yaw == pytest.approx(2 * math.pi - 6.0)
