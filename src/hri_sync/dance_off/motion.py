"""Human motion as a 15-joint stream in the sensor frame (no ROS).

``load_motion(path)`` reads a BVH file (any skeleton ``hri_sync.dance_off.bvh``
can map), a converted ``.npz`` or a ``.track`` file from ``data/motion/`` and
returns a ``Motion`` in the SENSOR FRAME of interfaces.md: OpenNI convention,
metres, x to the sensor's right, y up, z away from the sensor along its optical
axis, sensor 1.0 m above the floor (floor: y = -1.0).

A BVH clip is turned into that frame by:

1. scaling so the clip's standing height is ``height`` (1.70 m): the
   standing height is the 90th percentile over frames of the highest point
   of the head segment (head joint and its descendants: eyes, end site)
   above the lowest point of the whole body in that frame;
2. putting the floor (median over frames of the body's lowest point,
   toe end sites included) at y = -1.0;
3. turning the dancer about the vertical so that, on average, they face
   the sensor (their left hip on the sensor's right);
4. placing the mean torso position (x, z) at (0, 2.5); per-frame travel
   is kept.

Orientations are each joint's global rotation relative to the BVH rest
pose, expressed in the sensor frame, as quaternions (x, y, z, w). The
``.track`` format holds positions only; a Motion read from it has identity
orientations. Converted ``.npz`` files store positions to 0.1 mm and
quaternion components to 1/32767.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from typing import Optional, TYPE_CHECKING

import numpy as np

from hri_sync.dance_off import bvh as bvh_mod
from hri_sync.dance_off.joints import INDEX, JOINTS, NUM_JOINTS

if TYPE_CHECKING:
    from hri_sync.dance_off.bvh import Bvh

STANDING_HEIGHT = 1.70      # m
SENSOR_HEIGHT = 1.0         # m above the floor
SUBJECT_DISTANCE = 2.5      # m, mean torso z
HEIGHT_PERCENTILE = 90.0
MODES = ('clamp', 'loop', 'pingpong')
NPZ_POSITION_UNIT = 1e-4    # m: converted files store 0.1 mm steps
NPZ_QUATERNION_SCALE = 32767.0


@dataclass
class Motion:
    """Joint positions over time; ``times`` in s, strictly increasing."""

    times: np.ndarray               # (N,)
    positions: np.ndarray           # (N, 15, 3) metres, sensor frame
    # (N, 15, 4) quaternions x, y, z, w
    orientations: Optional[np.ndarray] = None
    name: str = ''

    def __post_init__(self) -> None:
        self.times = np.asarray(self.times, dtype=float)
        self.positions = np.asarray(self.positions, dtype=float)
        count = self.times.shape[0]
        if self.positions.shape != (count, NUM_JOINTS, 3):
            raise ValueError('Motion %s: positions shape %s, expected '
                             '(%d, %d, 3)' % (self.name, self.positions.shape,
                                              count, NUM_JOINTS))
        if count < 2 or not np.all(np.diff(self.times) > 0):
            raise ValueError('Motion %s: needs >= 2 frames with increasing '
                             'times' % self.name)
        if self.orientations is None:
            self.orientations = np.zeros((count, NUM_JOINTS, 4))
            self.orientations[..., 3] = 1.0
        self.orientations = np.asarray(self.orientations, dtype=float)

    @property
    def duration(self) -> float:
        return float(self.times[-1] - self.times[0])

    @property
    def rate(self) -> float:
        """Mean frame rate, Hz."""
        return (len(self.times) - 1) / self.duration

    def clip_time(self, t: np.ndarray | list[float],
                  mode: str = 'pingpong') -> np.ndarray:
        """Map times (s, any range) onto the clip's own timeline.

        ``clamp`` holds the first/last frame, ``loop`` wraps around (a jump
        at the seam), ``pingpong`` plays forward then backward (no jump: the
        default for replaying a clip longer than it lasts).
        """
        if mode not in MODES:
            raise ValueError('mode must be one of %s, not %r' % (MODES, mode))
        t = np.asarray(t, dtype=float) - self.times[0]
        dur = self.duration
        if mode == 'clamp':
            t = np.clip(t, 0.0, dur)
        elif mode == 'loop':
            t = np.mod(t, dur)
        else:
            t = np.mod(t, 2.0 * dur)
            t = np.where(t > dur, 2.0 * dur - t, t)
        return t + self.times[0]

    def _interp(self, times: np.ndarray | list[float],
                mode: str) -> tuple[np.ndarray, np.ndarray]:
        t = self.clip_time(times, mode)
        idx = np.clip(np.searchsorted(self.times, t, side='right') - 1,
                      0, len(self.times) - 2)
        t0, t1 = self.times[idx], self.times[idx + 1]
        w = np.clip((t - t0) / (t1 - t0), 0.0, 1.0)
        return idx, w

    def positions_at(self, times: np.ndarray | list[float],
                     mode: str = 'pingpong') -> np.ndarray:
        """Linearly interpolated positions (M, 15, 3) at ``times``."""
        idx, w = self._interp(times, mode)
        w = w[..., None, None]
        return self.positions[idx] * (1.0 - w) + self.positions[idx + 1] * w

    def orientations_at(self, times: np.ndarray,
                        mode: str = 'pingpong') -> np.ndarray:
        """Normalised-lerp quaternions (M, 15, 4) at ``times``."""
        idx, w = self._interp(times, mode)
        assert self.orientations is not None  # set by __post_init__
        q0, q1 = self.orientations[idx], self.orientations[idx + 1]
        sign = np.where(np.sum(q0 * q1, axis=-1, keepdims=True) < 0, -1.0, 1.0)
        q = q0 * (1.0 - w[..., None, None]) + sign * q1 * w[..., None, None]
        return q / np.linalg.norm(q, axis=-1, keepdims=True)

    def resample(self, rate: float) -> 'Motion':
        """The motion sampled at ``rate`` Hz from its start (clamped)."""
        count = int(np.floor(self.duration * rate + 1e-9)) + 1
        times = self.times[0] + np.arange(count) / float(rate)
        return Motion(times - self.times[0], self.positions_at(times, 'clamp'),
                      self.orientations_at(times, 'clamp'), self.name)

    def save_npz(self, path: str) -> None:
        """Compact file: positions in 0.1 mm (int32), orientations int16."""
        assert self.orientations is not None  # set by __post_init__
        np.savez_compressed(
            path, times=self.times,
            positions=np.round(self.positions / NPZ_POSITION_UNIT).astype(
                np.int32),
            orientations=np.round(self.orientations * NPZ_QUATERNION_SCALE
                                  ).astype(np.int16),
            joints=np.array(JOINTS), name=np.array(self.name))

    def save_track(self, path: str, comment: str = '') -> None:
        """The plain-text ``.track`` of interfaces.md (positions only)."""
        flat = np.concatenate([self.times[:, None] - self.times[0],
                               self.positions.reshape(len(self.times), -1)],
                              axis=1)
        header = ['hri_sync joint track: t x0 y0 z0 ... x14 y14 z14',
                  't in s from 0; metres, sensor frame (x right, y up, '
                  'z away from the sensor; floor y = -1.0)',
                  'joints: ' + ' '.join(JOINTS),
                  'rate: %.3f Hz, frames: %d' % (self.rate, len(self.times))]
        header += [c for c in comment.split('\n') if c]
        np.savetxt(path, flat, fmt=['%.4f'] + ['%.4f'] * (NUM_JOINTS * 3),
                   header='\n'.join(header), comments='# ')


def load_motion(path: str, height: float = STANDING_HEIGHT) -> Motion:
    """Read a .bvh, .npz or .track file as a Motion in the sensor frame.

    ``height`` applies to BVH input only (converted files are already
    scaled). Errors name the file: ``bvh.BvhError`` for BVH problems,
    ``ValueError`` for the others.
    """
    ext = os.path.splitext(path)[1].lower()
    name = os.path.splitext(os.path.basename(path))[0]
    if ext == '.bvh':
        return motion_from_bvh(bvh_mod.read_bvh(path), height, name)
    if ext == '.npz':
        try:
            with np.load(path) as data:
                joints = tuple(str(j) for j in data['joints'])
                if joints != JOINTS:
                    raise ValueError('%s: joint order %s differs from '
                                     'hri_sync.dance_off.joints'
                                     % (path, joints))
                quat = data['orientations'] / NPZ_QUATERNION_SCALE
                return Motion(data['times'],
                              data['positions'] * NPZ_POSITION_UNIT,
                              quat / np.linalg.norm(quat, axis=-1,
                                                    keepdims=True), name)
        except (OSError, KeyError) as exc:
            raise ValueError('%s: not a converted motion file (%s)'
                             % (path, exc))
    if ext == '.track':
        return read_track(path)
    raise ValueError('%s: unknown motion file type %r (use .bvh, .npz or '
                     '.track)' % (path, ext))


def read_track(path: str) -> Motion:
    """Read a ``.track`` file (identity orientations)."""
    try:
        data = np.loadtxt(path, comments='#', ndmin=2)
    except (OSError, ValueError) as exc:
        raise ValueError('%s: cannot read track: %s' % (path, exc))
    if data.shape[1] != 1 + 3 * NUM_JOINTS:
        raise ValueError('%s: %d columns per line, expected %d'
                         % (path, data.shape[1], 1 + 3 * NUM_JOINTS))
    name = os.path.splitext(os.path.basename(path))[0]
    return Motion(data[:, 0], data[:, 1:].reshape(-1, NUM_JOINTS, 3),
                  name=name)


def _head_segment(bvh: Bvh, head_index: int) -> list[int]:
    """Indices of the head joint and all its descendants."""
    out = [head_index]
    for i, joint in enumerate(bvh.joints):
        if joint.parent in out:
            out.append(i)
    return out


def standing_height(bvh: Bvh) -> float:
    """The clip's standing height in file units (see module docstring)."""
    mapping = bvh_mod.map_joints(bvh)
    pos, _ = bvh.forward_kinematics()
    head = _head_segment(bvh, mapping[INDEX['head']][0])
    extent = pos[:, head, 1].max(axis=1) - pos[:, :, 1].min(axis=1)
    return float(np.percentile(extent, HEIGHT_PERCENTILE))


def motion_from_bvh(bvh: Bvh, height: float = STANDING_HEIGHT,
                    name: str = '') -> Motion:
    """Turn a parsed BVH clip into a sensor-frame Motion (module docstring)."""
    mapping = bvh_mod.map_joints(bvh)
    pos_all, rot_all = bvh.forward_kinematics()
    head = _head_segment(bvh, mapping[INDEX['head']][0])
    extent = pos_all[:, head, 1].max(axis=1) - pos_all[:, :, 1].min(axis=1)
    file_height = float(np.percentile(extent, HEIGHT_PERCENTILE))
    if not file_height > 0:
        raise bvh_mod.BvhError('%s: cannot measure the standing height '
                               '(head not above the body)' % bvh.path)
    scale = height / file_height
    floor = float(np.median(pos_all[:, :, 1].min(axis=1)))

    pos = np.stack([pos_all[:, list(m)].mean(axis=1) for m in mapping], axis=1)
    rot = rot_all[:, [m[0] for m in mapping]]

    # Face the sensor: mean left-hip direction (horizontal) onto +x.
    left = pos[:, INDEX['left_hip']] - pos[:, INDEX['right_hip']]
    yaw = np.arctan2(left[:, 2].mean(), left[:, 0].mean())
    c, s = np.cos(yaw), np.sin(yaw)
    turn = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    mirror = np.diag([1.0, 1.0, -1.0])      # BVH right-handed -> sensor frame
    to_sensor = mirror @ turn

    out = np.einsum('ij,fkj->fki', to_sensor, pos) * scale
    out[..., 1] += -floor * scale - SENSOR_HEIGHT
    torso = out[:, INDEX['torso']]
    out[..., 0] -= torso[:, 0].mean()
    out[..., 2] += SUBJECT_DISTANCE - torso[:, 2].mean()

    rot_sensor = to_sensor @ rot @ np.linalg.inv(to_sensor)
    if bvh.num_frames < 2:
        raise bvh_mod.BvhError('%s: %d frame of motion, need at least 2'
                               % (bvh.path, bvh.num_frames))
    times = np.arange(bvh.num_frames) * bvh.frame_time
    return Motion(times, out, matrix_to_quaternion(rot_sensor), name)


def matrix_to_quaternion(mats: np.ndarray) -> np.ndarray:
    """Rotation matrices (..., 3, 3) to unit quaternions (..., 4) x, y, z, w.

    Shepperd's method: each element uses the best-conditioned of the four
    formulas, so 180-degree rotations are exact too.
    """
    m = np.asarray(mats, dtype=float)
    m00, m01, m02 = m[..., 0, 0], m[..., 0, 1], m[..., 0, 2]
    m10, m11, m12 = m[..., 1, 0], m[..., 1, 1], m[..., 1, 2]
    m20, m21, m22 = m[..., 2, 0], m[..., 2, 1], m[..., 2, 2]
    cands = []
    for big, xyzw in (
            (1.0 + m00 + m11 + m22,
             lambda r: (m21 - m12, m02 - m20, m10 - m01, r * r)),
            (1.0 + m00 - m11 - m22,
             lambda r: (r * r, m01 + m10, m02 + m20, m21 - m12)),
            (1.0 - m00 + m11 - m22,
             lambda r: (m01 + m10, r * r, m12 + m21, m02 - m20)),
            (1.0 - m00 - m11 + m22,
             lambda r: (m02 + m20, m12 + m21, r * r, m10 - m01))):
        r = np.sqrt(np.maximum(big, 1e-12))
        cands.append(np.stack(xyzw(r), axis=-1) / (2.0 * r[..., None]))
    stacked = np.stack(cands, axis=-2)                  # (..., 4, 4)
    best = np.argmax(np.stack([m00 + m11 + m22, m00, m11, m22], axis=-1),
                     axis=-1)
    q = np.take_along_axis(stacked, best[..., None, None],
                           axis=-2)[..., 0, :]
    return q / np.linalg.norm(q, axis=-1, keepdims=True)
