"""Poses of a site's frames in one ``world`` frame (no ROS).

``world`` follows REP 103 (x forward, y left, z up). ``hri_sync/Skeleton``
positions are in OpenNI's frame (x to the sensor's right, y up, z away from
the sensor), which is left-handed: no rotation (no tf) maps it into world.
A sensor's tf frame is therefore that frame mirrored in x (x to the
sensor's left, y up, z away: right-handed), as openni_tracker does; the
markers mirror the positions the same way (``skeleton_point``). A robot's
``odom`` frame is a REP 103 frame. ``pose`` gives the translation and
quaternion of either kind of frame from a position, a heading (yaw, rad,
about world z from world x) and a downward tilt (pitch, rad).
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np


SENSOR = 'sensor'       # x left, y up, z forward (Skeleton's x mirrored)
REP103 = 'rep103'       # x forward, y left, z up (odom, base_footprint)

# Columns: the sensor frame's x, y, z axes in a REP 103 body frame.
_SENSOR_AXES = np.array([[0.0, 0.0, 1.0],
                         [1.0, 0.0, 0.0],
                         [0.0, 1.0, 0.0]])


def skeleton_point(p: Sequence[float]) -> tuple[float, ...]:
    """A Skeleton position (x right, y up, z forward) in the sensor's tf
    frame (x left)."""
    return (-p[0], p[1], p[2])


def rotation(yaw: float, pitch: float = 0.0,
             convention: str = REP103) -> np.ndarray:
    """3x3 rotation of a frame's axes into world: heading ``yaw`` about z,
    then tilted down by ``pitch`` (positive: looking down)."""
    if convention not in (SENSOR, REP103):
        raise ValueError('frame convention must be %r or %r, not %r'
                         % (SENSOR, REP103, convention))
    cy, sy = math.cos(yaw), math.sin(yaw)
    cp, sp = math.cos(pitch), math.sin(pitch)
    rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    r = rz @ ry
    return r @ _SENSOR_AXES if convention == SENSOR else r


def quaternion(r: np.ndarray) -> tuple[float, ...]:
    """(x, y, z, w) of a 3x3 rotation matrix (Shepperd's method), w >= 0."""
    t = r[0, 0] + r[1, 1] + r[2, 2]
    k = int(np.argmax([t, r[0, 0], r[1, 1], r[2, 2]]))
    if k == 0:
        s = 2 * math.sqrt(1 + t)
        q = ((r[2, 1] - r[1, 2]) / s, (r[0, 2] - r[2, 0]) / s,
             (r[1, 0] - r[0, 1]) / s, s / 4)
    elif k == 1:
        s = 2 * math.sqrt(1 + r[0, 0] - r[1, 1] - r[2, 2])
        q = (s / 4, (r[0, 1] + r[1, 0]) / s, (r[0, 2] + r[2, 0]) / s,
             (r[2, 1] - r[1, 2]) / s)
    elif k == 2:
        s = 2 * math.sqrt(1 + r[1, 1] - r[0, 0] - r[2, 2])
        q = ((r[0, 1] + r[1, 0]) / s, s / 4, (r[1, 2] + r[2, 1]) / s,
             (r[0, 2] - r[2, 0]) / s)
    else:
        s = 2 * math.sqrt(1 + r[2, 2] - r[0, 0] - r[1, 1])
        q = ((r[0, 2] + r[2, 0]) / s, (r[1, 2] + r[2, 1]) / s, s / 4,
             (r[1, 0] - r[0, 1]) / s)
    return tuple(-v for v in q) if q[3] < 0 else q


def pose(x: float, y: float, z: float, yaw: float, pitch: float = 0.0,
         convention: str = REP103
         ) -> tuple[tuple[float, float, float], tuple[float, ...]]:
    """((x, y, z), (qx, qy, qz, qw)) of a frame in world."""
    values = (x, y, z, yaw, pitch)
    if not all(math.isfinite(v) for v in values):
        raise ValueError('a frame pose must be finite, not %r' % (values,))
    return (x, y, z), quaternion(rotation(yaw, pitch, convention))
