"""Joint names of other skeleton formats and their map to the 15
OpenNI/NiTE joints of ``hri_sync/Skeleton`` (``hri_sync.dance_off.joints``).

Each map gives, for each of the 15 joints in order, the source joint (or
the source joints averaged) it is taken from. Left and right are the
person's own, in every format. Positions convert into the Skeleton frame
(x to the sensor's right, y up, z away from the sensor, metres):

- Kinect v1 and v2 SDK camera space: x grows to the sensor's left, so
  x is negated (``KINECT_AXES``); hri_sync's own ``<client>_sensor`` tf
  frames have these axes too (``hri_sync.dance_off.frames``);
- Azure Kinect (k4abt) depth camera: x right, y down, z forward, so y is
  negated (``OPTICAL_AXES``);
- a REP 103 frame (x forward, y left, z up: ``openni_depth_frame``, a
  REP 155 camera frame): Skeleton = (-y, z, x) (``REP103_AXES``).
"""
import numpy as np

from hri_sync.dance_off.joints import JOINTS

# Kinect for Windows SDK 1.8, NUI_SKELETON_POSITION_INDEX order.
KINECT_V1 = (
    'HipCenter', 'Spine', 'ShoulderCenter', 'Head', 'ShoulderLeft',
    'ElbowLeft', 'WristLeft', 'HandLeft', 'ShoulderRight', 'ElbowRight',
    'WristRight', 'HandRight', 'HipLeft', 'KneeLeft', 'AnkleLeft',
    'FootLeft', 'HipRight', 'KneeRight', 'AnkleRight', 'FootRight')
# Kinect for Windows SDK 2.0, JointType order.
KINECT_V2 = (
    'SpineBase', 'SpineMid', 'Neck', 'Head', 'ShoulderLeft', 'ElbowLeft',
    'WristLeft', 'HandLeft', 'ShoulderRight', 'ElbowRight', 'WristRight',
    'HandRight', 'HipLeft', 'KneeLeft', 'AnkleLeft', 'FootLeft', 'HipRight',
    'KneeRight', 'AnkleRight', 'FootRight', 'SpineShoulder', 'HandTipLeft',
    'ThumbLeft', 'HandTipRight', 'ThumbRight')
# Azure Kinect Body Tracking SDK, k4abt_joint_id_t order (32 joints).
K4ABT = (
    'PELVIS', 'SPINE_NAVEL', 'SPINE_CHEST', 'NECK', 'CLAVICLE_LEFT',
    'SHOULDER_LEFT', 'ELBOW_LEFT', 'WRIST_LEFT', 'HAND_LEFT',
    'HANDTIP_LEFT', 'THUMB_LEFT', 'CLAVICLE_RIGHT', 'SHOULDER_RIGHT',
    'ELBOW_RIGHT', 'WRIST_RIGHT', 'HAND_RIGHT', 'HANDTIP_RIGHT',
    'THUMB_RIGHT', 'HIP_LEFT', 'KNEE_LEFT', 'ANKLE_LEFT', 'FOOT_LEFT',
    'HIP_RIGHT', 'KNEE_RIGHT', 'ANKLE_RIGHT', 'FOOT_RIGHT', 'HEAD', 'NOSE',
    'EYE_LEFT', 'EAR_LEFT', 'EYE_RIGHT', 'EAR_RIGHT')


def _limbs(shoulder, elbow, hand, hip, knee, foot):
    """The 12 limb joints of the 15, left before right as in JOINTS."""
    return (shoulder[0], shoulder[1], elbow[0], elbow[1], hand[0], hand[1],
            hip[0], hip[1], knee[0], knee[1], foot[0], foot[1])


FROM_KINECT_V1 = (('Head',), ('ShoulderCenter',), ('Spine',)) + tuple(
    (n,) for n in _limbs(
        ('ShoulderLeft', 'ShoulderRight'), ('ElbowLeft', 'ElbowRight'),
        ('HandLeft', 'HandRight'), ('HipLeft', 'HipRight'),
        ('KneeLeft', 'KneeRight'), ('FootLeft', 'FootRight')))
FROM_KINECT_V2 = (('Head',), ('Neck',), ('SpineMid',)) + FROM_KINECT_V1[3:]
FROM_K4ABT = (('HEAD',), ('NECK',), ('SPINE_NAVEL',)) + tuple(
    (n,) for n in _limbs(
        ('SHOULDER_LEFT', 'SHOULDER_RIGHT'), ('ELBOW_LEFT', 'ELBOW_RIGHT'),
        ('HAND_LEFT', 'HAND_RIGHT'), ('HIP_LEFT', 'HIP_RIGHT'),
        ('KNEE_LEFT', 'KNEE_RIGHT'), ('FOOT_LEFT', 'FOOT_RIGHT')))
# openni_tracker / openni2_tracker: the 15 NiTE joints, frames <joint>_<n>.
FROM_OPENNI = tuple((n,) for n in JOINTS)
# ros4hri human_description links (without the _<id> suffix). Its torso
# link sits at the top of the torso (the shoulder line: NiTE's neck) and
# body/waist at the hips' centre: NiTE's torso is taken between the two.
FROM_HUMAN_DESCRIPTION = (('head',), ('torso',), ('torso', 'waist')) + tuple(
    (n,) for n in _limbs(
        ('l_shoulder', 'r_shoulder'), ('l_elbow', 'r_elbow'),
        ('l_wrist', 'r_wrist'), ('l_hip', 'r_hip'), ('l_knee', 'r_knee'),
        ('l_ankle', 'r_ankle')))

KINECT_AXES = np.array([-1.0, 1.0, 1.0])
OPTICAL_AXES = np.array([1.0, -1.0, 1.0])
CONVENTIONS = ('optical', 'rep103', 'kinect')


def to_skeleton_frame(points, convention):
    """(..., 3) points of a frame of ``convention`` in the Skeleton frame:
    'optical' (x right, y down, z forward), 'rep103' (x forward, y left,
    z up) or 'kinect' (x left, y up, z forward)."""
    p = np.asarray(points, dtype=float)
    if convention == 'optical':
        return p * OPTICAL_AXES
    if convention == 'kinect':
        return p * KINECT_AXES
    if convention == 'rep103':
        return np.stack([-p[..., 1], p[..., 2], p[..., 0]], axis=-1)
    raise ValueError('frame convention must be one of %s, not %r'
                     % (', '.join(CONVENTIONS), convention))


def select(points, names, joint_map):
    """The 15 joints (15, 3) from ``points`` (N, 3) named ``names``
    (a tuple of source joint names) by ``joint_map``; a joint whose
    sources are not all there (or not finite) is NaN."""
    index = {n: i for i, n in enumerate(names)}
    out = np.full((len(joint_map), 3), np.nan)
    for j, sources in enumerate(joint_map):
        if all(s in index for s in sources):
            out[j] = np.mean([points[index[s]] for s in sources], axis=0)
    return out


def from_skeleton_frame(points, convention):
    """The inverse of ``to_skeleton_frame``."""
    p = np.asarray(points, dtype=float)
    if convention == 'rep103':
        return np.stack([p[..., 2], -p[..., 0], p[..., 1]], axis=-1)
    return to_skeleton_frame(p, convention)     # its own inverse
