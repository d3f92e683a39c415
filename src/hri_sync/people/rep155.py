"""hri_sync/Skeleton as REP 155 (ROS4HRI) bodies (no ROS).

A body's tf tree uses the link names of ros4hri's ``human_description``
(``body_<id>``, ``waist_<id>``, ``torso_<id>``, ``head_<id>``,
``l_shoulder_<id>``, ``l_elbow_<id>``, ``l_wrist_<id>``, ``l_hip_<id>``,
``l_knee_<id>``, ``l_ankle_<id>``, the right side's ``r_``, and the
intermediate ``r_head``/``y_head``/``p_head``, ``*_y_shoulder``,
``*_p_shoulder``, ``*_y_hip``, ``*_p_hip`` links), each under its URDF
parent. ``body_<id>`` sits at the hips' centre in the sensor's tf frame,
turned as the person faces (REP 103 axes: x forward, y to the person's
left, z up); every other link keeps body_<id>'s orientation and sits
where its joint is: ``torso`` at the shoulders' centre (NiTE's neck),
``head`` at the head, ``*_wrist`` at the hands, ``*_ankle`` at the feet;
``waist`` and the intermediate links at their parent's place. So a
lookup of any link in the sensor frame gives the tracked joint.
"""
import numpy as np

from hri_sync.dance_off.frames import quaternion
from hri_sync.dance_off.joints import INDEX
from hri_sync.people.adapters import HUMAN_LINKS
from hri_sync.people.joint_maps import from_skeleton_frame

# Links placed at a tracked joint; the others sit at their parent.
AT_JOINT = {
    'torso': 'neck', 'head': 'head',
    'l_shoulder': 'left_shoulder', 'r_shoulder': 'right_shoulder',
    'l_elbow': 'left_elbow', 'r_elbow': 'right_elbow',
    'l_wrist': 'left_hand', 'r_wrist': 'right_hand',
    'l_hip': 'left_hip', 'r_hip': 'right_hip',
    'l_knee': 'left_knee', 'r_knee': 'right_knee',
    'l_ankle': 'left_foot', 'r_ankle': 'right_foot',
}


def _depth(link):
    parent = HUMAN_LINKS[link]
    return 0 if parent is None else 1 + _depth(parent)


ORDER = sorted(HUMAN_LINKS, key=_depth)      # parents before children


def body_axes(points):
    """3x3 axes (columns x, y, z) of a person in the sensor tf frame:
    z up along hips -> shoulders, y to the person's left (right hip ->
    left hip), x forward; None when those joints are not tracked."""
    hips = points[INDEX['left_hip']] - points[INDEX['right_hip']]
    up = points[INDEX['neck']] - (points[INDEX['left_hip']]
                                  + points[INDEX['right_hip']]) / 2
    if not (np.isfinite(hips).all() and np.isfinite(up).all()) \
            or np.linalg.norm(up) < 1e-6:
        return None
    z = up / np.linalg.norm(up)
    y = hips - (hips @ z) * z
    if np.linalg.norm(y) < 1e-6:
        return None
    y = y / np.linalg.norm(y)
    return np.column_stack([np.cross(y, z), y, z])


def body_transforms(body_id, positions, convention='kinect'):
    """[(parent, child, (x, y, z), (qx, qy, qz, qw))] of one body, the
    first from the sensor frame (parent ``None``: the caller names it),
    or [] when the hips and neck are not tracked. ``positions``: (15, 3)
    in the Skeleton frame; ``convention``: the sensor frame's axes
    (hri_sync.people.joint_maps; 'kinect', x left, y up, z forward, is
    hri_sync's own <client>_sensor frame)."""
    points = from_skeleton_frame(positions, convention)
    axes = body_axes(points)
    if axes is None:
        return []
    hip_centre = (points[INDEX['left_hip']] + points[INDEX['right_hip']]) / 2
    place = {'body': hip_centre}
    out = [(None, 'body_%s' % body_id, tuple(hip_centre),
            quaternion(axes))]
    for link in ORDER:
        parent = HUMAN_LINKS[link]
        if parent is None:
            continue
        joint = AT_JOINT.get(link)
        p = points[INDEX[joint]] if joint else place[parent]
        if not np.isfinite(p).all():
            p = place[parent]           # an untracked joint: at its parent
        place[link] = p
        local = axes.T @ (p - place[parent])
        out.append(('%s_%s' % (parent, body_id), '%s_%s' % (link, body_id),
                    tuple(local), (0.0, 0.0, 0.0, 1.0)))
    return out


BODY_ID = '{client_id}{user_id}'    # a Skeleton's body id, by default


class TrackedBodies:
    """The bodies seen in the last ``forget_after`` s (the ids of
    ``/humans/bodies/tracked``), on a clock the caller gives."""

    def __init__(self, forget_after):
        self.forget_after = forget_after
        self.seen = {}          # body id -> (time last seen, its stamp)

    def saw(self, body_id, now, stamp):
        """``body_id`` seen at ``now``, its skeleton stamped ``stamp``."""
        self.seen[body_id] = (now, stamp)

    def tracked(self, now):
        """(sorted ids seen within ``forget_after`` of ``now``, the newest
        of their stamps or None); the others are forgotten."""
        for body in [b for b, (t, _) in self.seen.items()
                     if now - t > self.forget_after]:
            del self.seen[body]
        stamps = [s for _, s in self.seen.values()]
        return sorted(self.seen), (max(stamps) if stamps else None)
