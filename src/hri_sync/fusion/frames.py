"""Sensor poses and the world frame of the fusion.

``world`` is REP 103 (x forward, y left, z up, floor at z = 0).
``hri_sync/Skeleton`` positions are in the sensor's OpenNI frame (x right,
y up, z away); a sensor's pose is given as the site launch files give it:
position (m) and heading (yaw, rad, about world z from world x) and a
downward tilt (pitch, rad), hri_sync.dance_off.frames' ``sensor`` frame.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence, Union

import numpy as np

from hri_sync.dance_off.frames import SENSOR, rotation

MIRROR = np.array([-1.0, 1.0, 1.0])     # Skeleton frame -> sensor tf frame


@dataclass(frozen=True)
class SensorPose:
    """A sensor's pose in world."""

    x: float
    y: float
    z: float
    yaw: float
    pitch: float = 0.0

    def rotation(self) -> np.ndarray:
        """3x3: the sensor tf frame's axes in world."""
        return rotation(self.yaw, self.pitch, SENSOR)

    def translation(self) -> np.ndarray:
        """The sensor's position in world."""
        return np.array([self.x, self.y, self.z])

    def to_world(self, positions: np.ndarray) -> np.ndarray:
        """(..., 3) Skeleton-frame positions in world."""
        return ((np.asarray(positions, float) * MIRROR) @ self.rotation().T
                + self.translation())

    def from_world(self, points: np.ndarray) -> np.ndarray:
        """(..., 3) world points in the Skeleton frame."""
        local = (np.asarray(points, float) - self.translation()) \
            @ self.rotation()
        return local * MIRROR


def parse_pose(value: Union[str, Sequence[float]]) -> SensorPose:
    """A SensorPose from 'x y z yaw [pitch]' (or a list of 4-5 numbers)."""
    try:
        numbers = [float(v) for v in value.replace(',', ' ').split()] \
            if isinstance(value, str) else [float(v) for v in value]
    except (TypeError, ValueError):
        raise ValueError('a sensor pose is x y z yaw [pitch], not %r'
                         % (value,))
    if len(numbers) not in (4, 5) or not all(map(math.isfinite, numbers)):
        raise ValueError('a sensor pose is 4-5 finite numbers (x y z yaw '
                         '[pitch]), not %r' % (value,))
    return SensorPose(*numbers)


def facing(x: float, y: float, z: float, target: Sequence[float] = (0, 0)
           ) -> SensorPose:
    """A level sensor at (x, y, z) turned towards world (tx, ty)."""
    return SensorPose(x, y, z, math.atan2(target[1] - y, target[0] - x))
