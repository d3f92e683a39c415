"""Readers of the real Kinect skeleton recordings (no ROS).

``../shared/data/real_skeleton/`` (see its README): Kinect v2 captures of
microsoft/LabanotationSuite (MIT licence, Copyright (c) Microsoft
Corporation) and Kinect v1 sequences of the PRECOG dataset 2016 by David
Jardim (MIT licence). Each reader returns a ``Recording`` in the Skeleton
frame (``hri_sync.people.joint_maps``).
"""
from dataclasses import dataclass

import numpy as np

from hri_sync.people.joint_maps import (FROM_KINECT_V1, FROM_KINECT_V2,
                                        KINECT_V1, KINECT_V2, select,
                                        to_skeleton_frame)

KINECT_V1_RATE = 30.0       # Hz, nominal: the v1 files have no timestamps


@dataclass
class Recording:
    """A real sensor's skeleton stream, as the sensor gave it."""

    stamps: np.ndarray          # (N,) s from the first frame
    device_ticks: np.ndarray    # (N,) the sensor's own timestamps (int)
    positions: np.ndarray       # (N, 15, 3) m, Skeleton frame
    confidence: np.ndarray      # (N, 15): 1 tracked, 0.5 inferred, 0 not
    ankles: np.ndarray          # (N, 2, 3) m, left and right; NaN: not given

    def clip(self, t0, t1):
        """The frames stamped in [t0, t1) s, re-stamped from 0."""
        k = (self.stamps >= t0) & (self.stamps < t1)
        first = self.stamps[k][0]
        return Recording(self.stamps[k] - first, self.device_ticks[k],
                         self.positions[k], self.confidence[k],
                         self.ankles[k])


ANKLES = (('AnkleLeft',), ('AnkleRight',))


def given(points):
    """Which of the (..., 3) ``points`` a Kinect SDK gave: finite and not
    at 0 0 0 (where it puts a joint it does not track)."""
    return np.isfinite(points).all(axis=-1) & (points != 0).any(axis=-1)


def _ankles(points, names):
    """The (2, 3) ankles of one frame's ``points``; one not ``given`` is
    NaN."""
    a = select(points, names, ANKLES)
    a[~given(a)] = np.nan
    return a


def read_kinect_v2(path):
    """A LabanotationSuite CSV: a row per frame, the Kinect v2 timestamp
    (100 ns ticks), then 25 x (x, y, z, tracking state 0/1/2)."""
    with open(path) as f:
        rows = [[float(v) for v in line.strip().rstrip(',').split(',')]
                for line in f if line.strip()]
    a = np.array(rows)
    if a.ndim != 2 or a.shape[1] != 1 + 25 * 4:
        raise ValueError('%s: not a Kinect v2 joint file (%s columns)'
                         % (path, a.shape[1:] or 'ragged'))
    ticks = a[:, 0].astype(np.int64)
    joints = a[:, 1:].reshape(len(a), 25, 4)
    points = to_skeleton_frame(joints[:, :, :3], 'kinect')
    state = joints[:, :, 3] / 2.0
    positions = np.stack([select(p, KINECT_V2, FROM_KINECT_V2)
                          for p in points])
    confidence = np.stack([select(s[:, None], KINECT_V2, FROM_KINECT_V2)[:, 0]
                           for s in state])
    stamps = (ticks - ticks[0]) * 1e-7
    ankles = np.stack([_ankles(p, KINECT_V2) for p in points])
    return Recording(stamps, ticks, positions, confidence, ankles)


def read_kinect_v1(path):
    """A PRECOG CSV: a header of joint names, then a row per frame of 20
    'x y z' joints separated by ';' (and a trailing label field)."""
    with open(path) as f:
        lines = [line.strip() for line in f if line.strip()]
    names = tuple(n.strip() for n in lines[0].split(';'))[:20]
    if names != KINECT_V1:
        raise ValueError('%s: not a Kinect v1 joint file' % path)
    frames = np.array([[[float(v) for v in j.split()]
                        for j in line.split(';')[:20]] for line in lines[1:]])
    points = to_skeleton_frame(frames, 'kinect')
    positions = np.stack([select(p, KINECT_V1, FROM_KINECT_V1)
                          for p in points])
    n = len(positions)
    ankles = np.stack([_ankles(p, KINECT_V1) for p in points])
    return Recording(np.arange(n) / KINECT_V1_RATE, np.arange(n),
                     positions, np.ones((n, 15)), ankles)
