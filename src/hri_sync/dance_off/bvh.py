"""BVH motion capture files: parser, forward kinematics, 15-joint mapping.

Pure numpy, no ROS. ``read_bvh(path)`` parses the hierarchy and the motion
(channels in any order, each joint's Euler rotation order taken from the
order of its rotation channels), ``Bvh.forward_kinematics()`` gives every
joint's (and end site's) global position and rotation for all frames at
once, and ``map_joints`` picks the BVH joints behind the 15
``hri_sync.dance_off.joints.JOINTS``. Two skeleton sets are known (the 43-joint
"salsa" set and the 31-joint CMU set of ``/work/shared/data/mocap``) plus
the common Mixamo / MotionBuilder names; anything else raises ``BvhError``
naming the file and the joints that could not be found.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from hri_sync.dance_off.joints import JOINTS


END_SUFFIX = '_End'


class BvhError(ValueError):
    """A BVH file that cannot be parsed or mapped (the message names it)."""


@dataclass
class BvhJoint:
    """One node of the hierarchy (an End Site has no channels)."""

    name: str
    parent: int                 # index into Bvh.joints, -1 for the root
    offset: np.ndarray          # (3,) in file units
    channels: list = field(default_factory=list)
    channel_start: int = 0      # first column of this joint in the motion
    end_site: bool = False


@dataclass
class Bvh:
    """A parsed BVH file: hierarchy (parents before children) and motion."""

    path: str
    joints: list
    frame_time: float
    motion: np.ndarray          # (frames, channels) float64

    @property
    def num_frames(self) -> int:
        return self.motion.shape[0]

    @property
    def names(self) -> list[str]:
        return [j.name for j in self.joints]

    def index(self, name: str) -> int:
        """Index of a joint by name (exact match)."""
        for i, joint in enumerate(self.joints):
            if joint.name == name:
                return i
        raise KeyError(name)

    def forward_kinematics(
            self, frames: Sequence[int] | None = None,
            rest: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Global positions (F, J, 3) and rotations (F, J, 3, 3) of all joints.

        ``frames``: indices or slice of frames (default all). ``rest=True``
        gives the rest pose (offsets only, one frame, zero channels).
        Rotation channels compose in the order they are listed
        (``Zrotation Xrotation Yrotation`` gives Rz @ Rx @ Ry), applied to
        column vectors; a child's global position is its parent's plus the
        parent's global rotation applied to the child's offset (plus any
        position channels).
        """
        if rest:
            motion = np.zeros((1, self.motion.shape[1]))
        elif frames is None:
            motion = self.motion
        else:
            motion = self.motion[frames]
        count = motion.shape[0]
        num = len(self.joints)
        pos = np.zeros((count, num, 3))
        rot = np.zeros((count, num, 3, 3))
        for i, joint in enumerate(self.joints):
            local_t = np.broadcast_to(joint.offset, (count, 3)).copy()
            local_r = np.broadcast_to(np.eye(3), (count, 3, 3)).copy()
            for k, chan in enumerate(joint.channels):
                values = motion[:, joint.channel_start + k]
                axis = 'XYZ'.index(chan[0])
                if chan[1:] == 'position':
                    local_t[:, axis] += values
                else:
                    local_r = local_r @ _axis_rotation(axis, values)
            if joint.parent < 0:
                pos[:, i] = local_t
                rot[:, i] = local_r
            else:
                parent_r = rot[:, joint.parent]
                pos[:, i] = pos[:, joint.parent] + np.einsum(
                    'fij,fj->fi', parent_r, local_t)
                rot[:, i] = parent_r @ local_r
        return pos, rot


def _axis_rotation(axis: int, degrees: np.ndarray) -> np.ndarray:
    """Rotation matrices (F, 3, 3) about one axis by angles in degrees."""
    rad = np.radians(degrees)
    c, s = np.cos(rad), np.sin(rad)
    out = np.zeros(rad.shape + (3, 3))
    out[:, axis, axis] = 1.0
    a, b = [(1, 2), (2, 0), (0, 1)][axis]
    out[:, a, a] = c
    out[:, b, b] = c
    out[:, a, b] = -s
    out[:, b, a] = s
    return out


_CHANNELS = {'Xposition', 'Yposition', 'Zposition',
             'Xrotation', 'Yrotation', 'Zrotation'}


def read_bvh(path: str) -> Bvh:
    """Parse a BVH file; raise ``BvhError`` naming the file on any problem."""
    try:
        with open(path, 'r', errors='replace') as handle:
            text = handle.read()
    except OSError as exc:
        raise BvhError('%s: cannot read BVH file: %s' % (path, exc.strerror))
    return parse_bvh(text, path)


def parse_bvh(text: str, path: str = '<string>') -> Bvh:
    """Parse BVH text (``path`` only names the source in errors)."""
    head, sep, tail = text.partition('MOTION')
    if not sep:
        raise BvhError('%s: not a BVH file: no MOTION section' % path)
    tokens = head.split()
    if not tokens or tokens[0] != 'HIERARCHY':
        raise BvhError('%s: not a BVH file: does not start with HIERARCHY'
                       % path)
    joints = _parse_hierarchy(tokens[1:], path)
    num_channels = sum(len(j.channels) for j in joints)
    return Bvh(path, joints, *_parse_motion(tail, num_channels, path))


def _parse_hierarchy(tokens: list[str], path: str) -> list[BvhJoint]:
    # Over 80 lines: one token loop of the BVH grammar, each keyword a branch.
    joints: list[BvhJoint] = []
    stack: list[int] = []   # indices of open joints
    pending = None          # joint whose '{' is expected next
    channel = 0
    i = 0

    def need(count, what):
        if i + count >= len(tokens) + 1:
            raise BvhError('%s: hierarchy ends inside %s' % (path, what))

    while i < len(tokens):
        tok = tokens[i]
        if tok in ('ROOT', 'JOINT'):
            need(2, tok)
            if tok == 'ROOT' and (stack or joints):
                raise BvhError('%s: only one ROOT is supported' % path)
            if tok == 'JOINT' and not stack:
                raise BvhError('%s: JOINT %s outside ROOT'
                               % (path, tokens[i + 1]))
            pending = BvhJoint(tokens[i + 1], stack[-1] if stack else -1,
                               np.zeros(3))
            i += 2
        elif tok == 'End':
            if i + 1 >= len(tokens) or tokens[i + 1] != 'Site' or not stack:
                raise BvhError('%s: malformed End Site' % path)
            parent = joints[stack[-1]]
            name = parent.name + END_SUFFIX
            while any(j.name == name for j in joints):
                name += '_'
            pending = BvhJoint(name, stack[-1], np.zeros(3), end_site=True)
            i += 2
        elif tok == '{':
            if pending is None:
                raise BvhError('%s: unexpected "{" in hierarchy' % path)
            joints.append(pending)
            stack.append(len(joints) - 1)
            pending = None
            i += 1
        elif tok == '}':
            if not stack:
                raise BvhError('%s: unbalanced "}" in hierarchy' % path)
            stack.pop()
            i += 1
        elif tok == 'OFFSET':
            if not stack:
                raise BvhError('%s: OFFSET outside a joint' % path)
            try:
                joints[stack[-1]].offset = np.array(
                    [float(v) for v in tokens[i + 1:i + 4]])
            except ValueError:
                raise BvhError('%s: bad OFFSET of joint %s: %s'
                               % (path, joints[stack[-1]].name,
                                  ' '.join(tokens[i + 1:i + 4])))
            if joints[stack[-1]].offset.shape != (3,):
                raise BvhError('%s: OFFSET of joint %s has fewer than 3 values'
                               % (path, joints[stack[-1]].name))
            i += 4
        elif tok == 'CHANNELS':
            if not stack or joints[stack[-1]].end_site:
                raise BvhError('%s: CHANNELS outside a joint' % path)
            joint = joints[stack[-1]]
            try:
                count = int(tokens[i + 1])
            except (ValueError, IndexError):
                raise BvhError('%s: bad CHANNELS count of joint %s'
                               % (path, joint.name))
            names = tokens[i + 2:i + 2 + count]
            bad = [n for n in names if n not in _CHANNELS]
            if len(names) != count or bad:
                raise BvhError('%s: bad CHANNELS of joint %s: %s'
                               % (path, joint.name, ' '.join(names)))
            joint.channels = names
            joint.channel_start = channel
            channel += count
            i += 2 + count
        else:
            raise BvhError('%s: unexpected token %r in hierarchy'
                           % (path, tok))
    if stack or pending is not None:
        raise BvhError('%s: hierarchy not closed (missing "}")' % path)
    if not joints:
        raise BvhError('%s: empty hierarchy' % path)
    return joints


def _parse_motion(text: str, num_channels: int,
                  path: str) -> tuple[float, np.ndarray]:
    lines = text.split('\n')
    header = {}
    body_start = 0
    for k, line in enumerate(lines):
        stripped = line.strip()
        if not stripped:
            continue
        if stripped.startswith('Frames:'):
            header['frames'] = stripped[len('Frames:'):].strip()
        elif stripped.startswith('Frame Time:'):
            header['time'] = stripped[len('Frame Time:'):].strip()
            body_start = k + 1
            break
        else:
            raise BvhError('%s: expected "Frames:" and "Frame Time:" after '
                           'MOTION, got %r' % (path, stripped[:40]))
    try:
        frames = int(header['frames'])
        frame_time = float(header['time'])
    except (KeyError, ValueError):
        raise BvhError('%s: missing or bad "Frames:" / "Frame Time:" header'
                       % path)
    if frames <= 0 or not frame_time > 0:
        raise BvhError('%s: %d frames with frame time %s: need at least one '
                       'frame and a positive frame time'
                       % (path, frames, header['time']))
    try:
        values = np.array(' '.join(lines[body_start:]).split(), dtype=float)
    except ValueError as exc:
        raise BvhError('%s: non-numeric motion data (%s)' % (path, exc))
    expected = frames * num_channels
    if values.size < expected:
        raise BvhError('%s: motion data truncated: header says %d frames x %d '
                       'channels = %d values, file has %d'
                       % (path, frames, num_channels, expected, values.size))
    if values.size > expected:
        raise BvhError('%s: %d values of motion data, header says %d frames x '
                       '%d channels = %d' % (path, values.size, frames,
                                             num_channels, expected))
    motion = values.reshape(frames, num_channels)
    if not np.all(np.isfinite(motion)):
        bad = int(np.argmax(~np.all(np.isfinite(motion), axis=1)))
        raise BvhError('%s: non-finite motion value in frame %d' % (path, bad))
    return frame_time, motion


# Where each hri_sync joint sits in known skeleton sets: alternatives tried
# in order, each a tuple of BVH joint names (lower case, namespace prefix
# such as "mixamorig:" removed) whose positions are averaged.
_SIDE_JOINTS = {
    'shoulder': ['{s}shldr', '{side}arm', '{side}shoulder', '{s}shoulder'],
    'elbow': ['{s}forearm', '{side}forearm', '{side}elbow', '{s}elbow'],
    'hand': ['{s}hand', '{side}wrist', '{side}hand', '{s}wrist'],
    'hip': ['{s}thigh', '{side}upleg', '{side}hip', '{s}hip'],
    'knee': ['{s}shin', '{side}leg', '{side}knee', '{s}knee'],
    'foot': ['{s}foot', '{side}ankle', '{side}foot', '{s}ankle'],
}
JOINT_CANDIDATES: dict[str, list[tuple[str, ...]]] = {
    'head': [('head', 'head' + END_SUFFIX.lower()), ('head',)],
    'neck': [('neck',), ('neck1',)],
    'torso': [('abdomen', 'chest'), ('chest', 'chest2'), ('spine', 'spine1'),
              ('spine1',), ('spine',), ('chest',)],
}
for _side in ('left', 'right'):
    for _part, _patterns in _SIDE_JOINTS.items():
        JOINT_CANDIDATES['%s_%s' % (_side, _part)] = [
            (p.format(s=_side[0], side=_side),) for p in _patterns]


def _plain(name: str) -> str:
    return name.split(':')[-1].lower()


def map_joints(bvh: Bvh) -> list[tuple[int, ...]]:
    """For each of the 15 JOINTS, the tuple of BVH joint indices to average.

    Raises ``BvhError`` naming the file and every joint it could not find.
    """
    index: dict[str, int] = {}
    for i, joint in enumerate(bvh.joints):
        index.setdefault(_plain(joint.name), i)
    mapping, missing = [], []
    for name in JOINTS:
        for names in JOINT_CANDIDATES[name]:
            if all(n in index for n in names):
                mapping.append(tuple(index[n] for n in names))
                break
        else:
            looked = ' or '.join('+'.join(n) for n in JOINT_CANDIDATES[name])
            missing.append('%s (looked for %s)' % (name, looked))
    if missing:
        have = [j.name for j in bvh.joints if not j.end_site]
        raise BvhError('%s: lacks %d of the 15 hri_sync joints: %s (the '
                       "file's joints: %s%s)"
                       % (bvh.path, len(missing), '; '.join(missing),
                          ', '.join(have[:20]),
                          ', ...' if len(have) > 20 else ''))
    return mapping


def joints15(bvh: Bvh, frames: Sequence[int] | None = None,
             rest: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Positions (F, 15, 3) in file units and rotations (F, 15, 3, 3).

    The rotation of an averaged joint is that of its first BVH joint.
    """
    mapping = map_joints(bvh)
    pos, rot = bvh.forward_kinematics(frames, rest=rest)
    out_pos = np.stack([pos[:, list(m)].mean(axis=1) for m in mapping], axis=1)
    out_rot = rot[:, [m[0] for m in mapping]]
    return out_pos, out_rot
