"""Other trackers' skeletons as 15-joint ``Body`` frames (no ROS).

The core of ``nodes/skeleton_adapter``, which publishes each Body as an
``hri_sync/Skeleton``. Three formats:

- ``OpenniTf``: openni_tracker / openni2_tracker, one tf transform per
  joint (``head_<n>`` ... ``right_foot_<n>``, parent ``openni_depth_frame``,
  a REP 103 frame), each stamped with the host clock when it is sent;
- ``AzureKinectMarkers``: the Azure Kinect ROS driver's
  ``body_tracking_data`` (a MarkerArray; marker id = body id x 100 +
  joint index in the Body Tracking SDK's 32-joint order, frame
  ``depth_camera_link``, stamped with the capture's device time mapped
  to the host clock);
- ``Rep155Tf``: REP 155 bodies, the ``body_<id>`` tf tree with the
  ros4hri ``human_description`` link names (``head_<id>``,
  ``l_elbow_<id>``...), chains composed up to the reference frame.

Each adapter validates at the boundary and counts what it rejects in
``counts`` (reason -> frames): ``wrong_frame`` (a frame id of another
sensor), ``missing_joints`` (fewer than ``min_joints`` of the 15),
``bad_id`` (an id the format cannot have), ``out_of_range`` (a joint
farther than ``max_coordinate`` m), ``mixed_stamps`` (one body's joints
with different stamps), ``bad_stamp``, ``bad_transform`` (a REP 155
transform not finite, far, or with no rotation). It never raises on
input. Ids that jump (the
tracker gives the person in the same place a new id from one frame to
the next) are counted in ``counts['id_jumps']`` and, by default
(``reject_jumps`` False), passed on: the participant selector follows
the person across the new id (``hri_sync.people.participant``); with
``reject_jumps`` the frames of a jumped id are rejected (``id_jump``) for
as long as the old id was seen within the last 0.2 s.
"""
import math
from collections import Counter
from dataclasses import dataclass

import numpy as np

from hri_sync.dance_off.joints import JOINTS, NUM_JOINTS
from hri_sync.people.joint_maps import (FROM_HUMAN_DESCRIPTION, FROM_K4ABT,
                                        FROM_OPENNI, K4ABT,
                                        from_skeleton_frame, select,
                                        to_skeleton_frame)
from hri_sync.people.participant import body_point

MAX_COORDINATE = 100.0       # m, as hri_sync.wire.validate.Limits
SAME_PLACE = 0.25            # m: a new id this close to an old one: a jump


@dataclass
class Body:
    """One person's frame in the Skeleton frame."""

    stamp: float                # the source's stamp, s
    user_id: int
    positions: np.ndarray       # (15, 3) m; NaN: not tracked
    confidence: np.ndarray      # (15,)


class Adapter:
    """Validation and counting shared by the formats."""

    def __init__(self, source_frame, min_joints=NUM_JOINTS,
                 max_coordinate=MAX_COORDINATE, reject_jumps=False):
        if not 1 <= min_joints <= NUM_JOINTS:
            raise ValueError('min_joints must be within 1..%d, not %r'
                             % (NUM_JOINTS, min_joints))
        self.source_frame = source_frame
        self.min_joints = int(min_joints)
        self.max_coordinate = float(max_coordinate)
        self.reject_jumps = bool(reject_jumps)
        self.counts = Counter()
        self.frames = 0                 # Bodies made
        self._last = {}                 # user id -> (stamp, point)

    def reject(self, reason, n=1):
        """Count ``n`` frames rejected for ``reason``; returns []."""
        self.counts[reason] += n
        return []

    def body(self, stamp, user_id, positions, confidence=None,
             frame_id=None):
        """[Body] from (15, 3) Skeleton-frame positions, or [] (counted)."""
        if frame_id is not None and frame_id != self.source_frame:
            return self.reject('wrong_frame')
        if not math.isfinite(stamp) or stamp <= 0:
            return self.reject('bad_stamp')
        positions = np.asarray(positions, dtype=float)
        finite = np.isfinite(positions).all(axis=1)
        if np.any(np.abs(positions[finite]) > self.max_coordinate):
            return self.reject('out_of_range')
        if int(finite.sum()) < self.min_joints:
            return self.reject('missing_joints')
        if not finite.all():
            self.counts['joints_missing'] += int((~finite).sum())
            positions = np.where(finite[:, None], positions, np.nan)
        if confidence is None:
            confidence = np.ones(NUM_JOINTS)
        confidence = np.where(finite, np.clip(confidence, 0.0, 1.0), 0.0)
        if self._jumped(stamp, user_id, positions) and self.reject_jumps:
            return self.reject('id_jump')
        self.frames += 1
        return [Body(stamp, user_id, positions, confidence)]

    def _jumped(self, stamp, user_id, positions):
        """Whether ``user_id`` is a new id where another was a moment
        ago (counted once per new id)."""
        point = body_point(positions)
        for other in [u for u, (t, _, _) in self._last.items()
                      if stamp - t > 5.0]:
            del self._last[other]
        if point is None:
            return user_id in self._last and self._last[user_id][2]
        jumped = self._last[user_id][2] if user_id in self._last else False
        if user_id not in self._last:
            for other, (t, p, _) in self._last.items():
                if 0 <= stamp - t <= 0.2 and \
                        np.linalg.norm(point - p) < SAME_PLACE:
                    self.counts['id_jumps'] += 1
                    jumped = True
                    break
        if jumped and not any(0 <= stamp - t <= 0.2 for u, (t, _, j) in
                              self._last.items() if u != user_id and not j):
            jumped = False      # the old id is gone: this one is the person
        self._last[user_id] = (stamp, point, jumped)
        return jumped


def _user_number(text):
    """A positive int id from its text, or None."""
    if not text.isdigit():
        return None
    n = int(text)
    return n if 0 < n < 2 ** 32 else None


class OpenniTf(Adapter):
    """openni_tracker / openni2_tracker tf frames to Bodies.

    The tracker sends a user's 15 joints one transform at a time, each
    stamped at sending: a frame is the joints of one user that arrive
    together; it is complete with all 15, or ``window`` s after its first
    joint (``poll``), or when a joint of it comes again.  Its stamp is
    its first joint's.
    """

    def __init__(self, source_frame='openni_depth_frame',
                 min_joints=NUM_JOINTS, window=0.02, **kw):
        super().__init__(source_frame, min_joints, **kw)
        self.window = float(window)
        self._pending = {}      # user -> {'joints', 'stamp', 'arrival', 'bad'}

    def add(self, parent, child, stamp, translation, arrival):
        """One transform ``parent`` -> ``child`` (translation x, y, z in
        the parent frame) that arrived at ``arrival``: the Bodies it
        completes."""
        name, _, number = child.rpartition('_')
        if name not in JOINTS:
            self.counts['other_frames'] += 1     # not a skeleton joint
            return []
        user = _user_number(number)
        if user is None:
            return self.reject('bad_id')
        out = []
        group = self._pending.get(user)
        if group is not None and name in group['joints']:
            out += self._emit(user)
            group = None
        if group is None:
            group = self._pending[user] = {
                'joints': {}, 'stamp': stamp, 'arrival': arrival,
                'bad': False}
        group['bad'] |= parent != self.source_frame
        group['joints'][name] = translation
        if len(group['joints']) == NUM_JOINTS:
            out += self._emit(user)
        return out

    def poll(self, now):
        """Bodies of frames whose joints stopped coming ``window`` ago."""
        out = []
        for user in [u for u, g in self._pending.items()
                     if now - g['arrival'] >= self.window]:
            out += self._emit(user)
        return out

    def _emit(self, user):
        group = self._pending.pop(user)
        if group['bad']:
            return self.reject('wrong_frame')
        names = tuple(group['joints'])
        points = to_skeleton_frame(
            np.array([group['joints'][n] for n in names], dtype=float),
            'rep103')
        return self.body(group['stamp'], user,
                         select(points, names, FROM_OPENNI))


class AzureKinectMarkers(Adapter):
    """Azure Kinect ROS driver body markers to Bodies.

    Markers carry no confidence (every joint gets 1) and no frame of
    their own beyond each marker's header: a body is its markers in one
    MarkerArray, which must share one stamp and ``source_frame``.
    ``convention``: the frame's axes ('optical': x right, y down, z
    forward, the k4a depth camera's).
    """

    def __init__(self, source_frame='depth_camera_link',
                 convention='optical', min_joints=NUM_JOINTS, **kw):
        super().__init__(source_frame, min_joints, **kw)
        to_skeleton_frame(np.zeros(3), convention)     # checks it
        self.convention = convention

    def add(self, markers):
        """One MarkerArray as [(id, frame_id, stamp, (x, y, z), action)]
        (action 0: ADD/MODIFY; others delete and are skipped): its
        Bodies, in body id order."""
        bodies = {}
        for marker_id, frame_id, stamp, position, action in markers:
            if action != 0:
                self.counts['deleted_markers'] += 1
                continue
            body, joint = divmod(int(marker_id), 100)
            b = bodies.setdefault(body, {'joints': {}, 'frames': set(),
                                         'stamps': set(), 'bad_id': False})
            if marker_id < 0 or joint >= len(K4ABT) \
                    or joint in b['joints'] or not 0 <= body < 2 ** 32:
                b['bad_id'] = True
                continue
            b['joints'][joint] = position
            b['frames'].add(frame_id)
            b['stamps'].add(stamp)
        out = []
        for body in sorted(bodies):
            b = bodies[body]
            if b['bad_id']:
                out += self.reject('bad_id')
                continue
            if b['frames'] != {self.source_frame}:
                out += self.reject('wrong_frame')
                continue
            if max(b['stamps']) - min(b['stamps']) > 1e-3:
                out += self.reject('mixed_stamps')
                continue
            index = sorted(b['joints'])
            points = to_skeleton_frame(
                np.array([b['joints'][j] for j in index], dtype=float),
                self.convention)
            out += self.body(min(b['stamps']), body + 1, select(
                points, tuple(K4ABT[j] for j in index), FROM_K4ABT))
        return out


# human_description's links: name -> its parent link (URDF tree).
HUMAN_LINKS = {
    'body': None, 'waist': 'body', 'torso': 'waist', 'r_head': 'torso',
    'y_head': 'r_head', 'p_head': 'y_head', 'head': 'p_head',
}
for _s in ('l', 'r'):
    HUMAN_LINKS.update({
        _s + '_y_shoulder': 'torso', _s + '_p_shoulder': _s + '_y_shoulder',
        _s + '_shoulder': _s + '_p_shoulder', _s + '_elbow': _s + '_shoulder',
        _s + '_wrist': _s + '_elbow', _s + '_y_hip': 'body',
        _s + '_p_hip': _s + '_y_hip', _s + '_hip': _s + '_p_hip',
        _s + '_knee': _s + '_hip', _s + '_ankle': _s + '_knee'})
_BY_LENGTH = sorted(HUMAN_LINKS, key=len, reverse=True)


def split_link(frame):
    """('l_elbow', 'abcde') from 'l_elbow_abcde'; None if not a link."""
    for link in _BY_LENGTH:
        if frame.startswith(link + '_') and len(frame) > len(link) + 1:
            return link, frame[len(link) + 1:]
    return None


def rotation_matrix(q):
    """3x3 rotation of a quaternion (x, y, z, w), normalised; ValueError
    for one that is not finite or has no length."""
    q = np.asarray(q, dtype=float).reshape(4)
    norm = np.linalg.norm(q) if np.isfinite(q).all() else 0.0
    if not 1e-6 < norm < 1e6:
        raise ValueError('not a rotation: %r' % (q,))
    x, y, z, w = q / norm
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


class Rep155Tf(Adapter):
    """REP 155 bodies' tf trees to Bodies.

    Keeps each body's latest transform per link (static ones too) and
    composes each needed link's chain up to ``body_<id>``, whose parent
    must be ``source_frame`` (a frame of ``convention``, 'rep103' for a
    ROS camera link). A frame is the moving transforms of one stamp: it
    is made ``window`` s after they began to arrive (``poll``) or when a
    later stamp comes. REP 155 ids are strings: each new one gets the
    next user number (``ids``: string -> number).
    """

    def __init__(self, source_frame, convention='rep103',
                 min_joints=NUM_JOINTS, window=0.02, **kw):
        super().__init__(source_frame, min_joints, **kw)
        to_skeleton_frame(np.zeros(3), convention)
        self.convention = convention
        self.window = float(window)
        self.ids = {}
        self._links = {}        # id -> {link: (parent, t (3,), R (3, 3))}
        self._pending = {}      # id -> (stamp, arrival)

    def add(self, parent, child, stamp, translation, rotation, arrival,
            static=False):
        """One transform; returns the Bodies it completes."""
        parts = split_link(child)
        if parts is None:
            self.counts['other_frames'] += 1
            return []
        link, body = parts
        try:
            r = rotation_matrix(rotation)
            t = np.asarray(translation, dtype=float).reshape(3)
        except (ValueError, TypeError):
            return self.reject('bad_transform')
        if not (np.isfinite(t).all() and np.all(np.abs(t) <=
                                                 self.max_coordinate)):
            return self.reject('bad_transform')
        out = []
        pending = self._pending.get(body)
        if not static and pending is not None and \
                stamp > pending[0] + 1e-6:
            out += self._emit(body)
            pending = None
        self._links.setdefault(body, {})[link] = (parent, t, r)
        if not static and pending is None:
            self._pending[body] = (stamp, arrival)
        return out

    def poll(self, now):
        out = []
        for body in [b for b, (_, a) in self._pending.items()
                     if now - a >= self.window]:
            out += self._emit(body)
        return out

    def forget(self, body):
        """Drop a body no longer tracked (its links, its pending frame)."""
        self._links.pop(body, None)
        self._pending.pop(body, None)

    def _position(self, links, body, link, depth=0):
        """The link's origin in body_<id>'s frame (None: chain broken)."""
        if link == 'body':
            return np.zeros(3), np.eye(3)
        entry = links.get(link)
        if entry is None or depth > len(HUMAN_LINKS):
            return None
        parent, t, r = entry
        parts = split_link(parent)
        if parts is None or parts[1] != body:
            return None
        up = self._position(links, body, parts[0], depth + 1)
        if up is None:
            return None
        pt, pr = up
        return pt + pr @ t, pr @ r

    def _emit(self, body):
        stamp, _ = self._pending.pop(body)
        links = self._links.get(body, {})
        root = links.get('body')
        if root is None:
            return self.reject('missing_joints')
        if root[0] != self.source_frame:
            return self.reject('wrong_frame')
        _, bt, br = root
        names, points = [], []
        for link in sorted({s for src in FROM_HUMAN_DESCRIPTION
                            for s in src}):
            pose = self._position(links, body, link)
            if pose is not None:
                names.append(link)
                points.append(bt + br @ pose[0])
        if not names:
            return self.reject('missing_joints')
        user = self.ids.setdefault(body, len(self.ids) + 1)
        points = to_skeleton_frame(np.array(points), self.convention)
        return self.body(stamp, user, select(points, tuple(names),
                                             FROM_HUMAN_DESCRIPTION))


# -- what the trackers send (test bags, and the adapters' unit tests) --------

def openni_transforms(user, positions):
    """[(child, (x, y, z))] an openni_tracker sends for one frame of user
    ``user`` at ``positions`` (15, 3; Skeleton frame), in
    openni_depth_frame."""
    points = from_skeleton_frame(positions, 'rep103')
    return [('%s_%d' % (name, user), tuple(p))
            for name, p in zip(JOINTS, points)]


def azure_markers(body, positions, convention='optical'):
    """[(marker id, (x, y, z))] of the 32 k4abt joints the Azure Kinect
    driver sends for body ``body``: the 15 joints where they are (in the
    depth camera frame), the other 17 at the nearest of them."""
    points = from_skeleton_frame(positions, convention)
    nearest = {'PELVIS': 'torso', 'SPINE_CHEST': 'neck',
               'CLAVICLE_LEFT': 'left_shoulder',
               'CLAVICLE_RIGHT': 'right_shoulder'}
    where = {src[0]: points[j] for j, src in enumerate(FROM_K4ABT)}
    out = []
    for k, name in enumerate(K4ABT):
        if name in where:
            p = where[name]
        elif name in nearest:
            p = points[JOINTS.index(nearest[name])]
        elif name.endswith('LEFT') or name.endswith('RIGHT'):
            side = 'left' if name.endswith('LEFT') else 'right'
            limb = 'hand' if name[:4] in ('WRIS', 'HAND', 'THUM') else 'foot'
            p = points[JOINTS.index('%s_%s' % (side, limb))] if \
                name[:3] != 'EYE' and name[:3] != 'EAR' else \
                points[JOINTS.index('head')]
        else:
            p = points[JOINTS.index('head')]         # NOSE
        out.append((body * 100 + k, tuple(p)))
    return out
