"""Planar geometry of the robot: angles, yaw quaternions, odometry poses.

The lowest module of ``hri_sync.robot``: the base model, the dance, the
scheduler, the nodes and the test checkers take their angle wrapping and
their quaternion <-> yaw conversion from here.  Angles are radians,
counter-clockwise; quaternions are (x, y, z, w) like
``geometry_msgs/Quaternion``.
"""
import math

TWO_PI = 2.0 * math.pi


def wrap_angle(angle):
    """``angle`` (rad) wrapped to [-pi, pi)."""
    return (angle + math.pi) % TWO_PI - math.pi


def wrap_degrees(angle):
    """``angle`` (deg) wrapped to [-180, 180)."""
    return (angle + 180.0) % 360.0 - 180.0


def yaw_from_quaternion(x, y, z, w):
    """Yaw (rad, about +z) of the rotation quaternion (x, y, z, w)."""
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def yaw_of(q):
    """Yaw (rad) of an object with x, y, z, w (a geometry_msgs/Quaternion)."""
    return yaw_from_quaternion(q.x, q.y, q.z, q.w)


def quaternion_from_yaw(yaw):
    """The quaternion (x, y, z, w) of a rotation by ``yaw`` (rad) about z."""
    return (0.0, 0.0, math.sin(yaw / 2.0), math.cos(yaw / 2.0))


def relative_pose(origin, x, y, yaw):
    """The pose (x, y, yaw) in the frame of ``origin`` (x, y, yaw), all in
    one frame (e.g. odom): how far and which way the robot has moved from
    its start pose, yaw wrapped to [-pi, pi)."""
    ox, oy, oyaw = origin
    dx, dy = x - ox, y - oy
    c, s = math.cos(oyaw), math.sin(oyaw)
    return c * dx + s * dy, -s * dx + c * dy, wrap_angle(yaw - oyaw)
