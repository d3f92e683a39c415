"""BVH parsing, forward kinematics, joint mapping and the sensor frame."""

import os

import numpy as np
import pytest

from hri_sync.dance_off import bvh, motion
from hri_sync.dance_off.joints import INDEX

MOCAP = os.path.join(os.path.dirname(__file__), '..', '..', '..', 'shared',
                     'data', 'mocap')
if not os.path.isdir(MOCAP):
    MOCAP = '/work/shared/data/mocap'

TWO = """HIERARCHY
ROOT root
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition %s
  JOINT child
  {
    OFFSET 0 1 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    End Site
    {
      OFFSET 0 1 0
    }
  }
}
MOTION
Frames: 2
Frame Time: 0.5
1 2 3 90 90 0 0 0 0
0 0 0 0 0 0 0 0 90
"""


def test_rotation_order_follows_channel_order():
    zxy = bvh.parse_bvh(TWO % 'Zrotation Xrotation Yrotation')
    pos, rot = zxy.forward_kinematics()
    assert zxy.names == ['root', 'child', 'child_End']
    # Rz(90) @ Rx(90) applied to (0, 1, 0) is (0, 0, 1).
    np.testing.assert_allclose(pos[0, 1], [1, 2, 4], atol=1e-12)
    np.testing.assert_allclose(pos[0, 2], [1, 2, 5], atol=1e-12)
    xzy = bvh.parse_bvh(TWO % 'Xrotation Zrotation Yrotation')
    pos, _ = xzy.forward_kinematics()
    # Rx(90) @ Rz(90) applied to (0, 1, 0) is (-1, 0, 0).
    np.testing.assert_allclose(pos[0, 1], [0, 2, 3], atol=1e-12)
    # Frame 1: child's own Y rotation turns the end site's offset? No: the
    # end site lies on the child's y axis, which Ry leaves alone.
    pos, rot = zxy.forward_kinematics()
    np.testing.assert_allclose(pos[1, 2], [0, 2, 0], atol=1e-12)
    np.testing.assert_allclose(rot[1, 1], [[0, 0, 1], [0, 1, 0], [-1, 0, 0]],
                               atol=1e-12)


def test_rest_pose_and_frame_time():
    data = bvh.parse_bvh(TWO % 'Zrotation Xrotation Yrotation')
    assert data.frame_time == 0.5 and data.num_frames == 2
    pos, _ = data.forward_kinematics(rest=True)
    np.testing.assert_allclose(pos[0], [[0, 0, 0], [0, 1, 0], [0, 2, 0]])


@pytest.mark.parametrize('text, needle', [
    ('nothing here', 'no MOTION'),
    (TWO.replace('Frames: 2', 'Frames: 3') % 'Zrotation Xrotation Yrotation',
     'truncated'),
    (TWO.replace('  }\n}', '  }\n') % 'Zrotation Xrotation Yrotation',
     'not closed'),
    ((TWO % 'Zrotation Xrotation Yrotation').replace(
        'Yrotation\n  JOINT', 'Wrotation\n  JOINT'), 'bad CHANNELS'),
    (TWO.replace('1 2 3 90', '1 2 x 90') % 'Zrotation Xrotation Yrotation',
     'non-numeric'),
    (TWO.replace('Frame Time: 0.5', 'Frame Time: 0') % 'Zrotation Xrotation'
     ' Yrotation', 'positive frame time'),
])
def test_malformed_names_file_and_problem(text, needle):
    with pytest.raises(bvh.BvhError) as err:
        bvh.parse_bvh(text, '/data/bad.bvh')
    assert '/data/bad.bvh' in str(err.value)
    assert needle in str(err.value)


def test_missing_file():
    with pytest.raises(bvh.BvhError, match='/nonexistent/x.bvh'):
        bvh.read_bvh('/nonexistent/x.bvh')


def test_missing_joints_are_listed():
    data = bvh.parse_bvh(TWO % 'Zrotation Xrotation Yrotation', 'two.bvh')
    with pytest.raises(bvh.BvhError) as err:
        bvh.map_joints(data)
    msg = str(err.value)
    assert msg.startswith('two.bvh: lacks 15 of the 15')
    assert 'left_knee (looked for lshin or leftleg' in msg
    assert "(the file's joints: root, child)" in msg


# A minimal standing figure with the salsa file's joint names (y up, facing
# +z, units of 10 cm), rotated 90 degrees about y in frame 1.
FIGURE = """HIERARCHY
ROOT hip
{
  OFFSET 0 0 0
  CHANNELS 6 Xposition Yposition Zposition Yrotation Xrotation Zrotation
  JOINT abdomen
  {
    OFFSET 0 1 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT chest
    {
      OFFSET 0 1 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      JOINT neck
      {
        OFFSET 0 2 0
        CHANNELS 3 Zrotation Xrotation Yrotation
        JOINT head
        {
          OFFSET 0 1 0
          CHANNELS 3 Zrotation Xrotation Yrotation
          End Site
          {
            OFFSET 0 2 0
          }
        }
      }
%s
    }
  }
%s
}
MOTION
Frames: 2
Frame Time: 0.1
0 9 0 0 0 0 %s
0 9 0 90 0 0 %s
"""
ARM = """      JOINT {s}Shldr
      {{
        OFFSET {x} 1.5 0
        CHANNELS 3 Zrotation Xrotation Yrotation
        JOINT {s}ForeArm
        {{
          OFFSET {x} 0 0
          CHANNELS 3 Zrotation Xrotation Yrotation
          JOINT {s}Hand
          {{
            OFFSET {x} 0 0
            CHANNELS 3 Zrotation Xrotation Yrotation
          }}
        }}
      }}
"""
LEG = """  JOINT {s}Thigh
  {{
    OFFSET {x} 0 0
    CHANNELS 3 Zrotation Xrotation Yrotation
    JOINT {s}Shin
    {{
      OFFSET 0 -4 0
      CHANNELS 3 Zrotation Xrotation Yrotation
      JOINT {s}Foot
      {{
        OFFSET 0 -4 0
        CHANNELS 3 Zrotation Xrotation Yrotation
        End Site
        {{
          OFFSET 0 -1 1
        }}
      }}
    }}
  }}
"""


def figure_text():
    arms = ARM.format(s='l', x=1) + ARM.format(s='r', x=-1)
    legs = LEG.format(s='l', x=1) + LEG.format(s='r', x=-1)
    zeros = ' '.join(['0'] * (3 * 16))
    return FIGURE % (arms, legs, zeros, zeros)


def test_salsa_names_map_and_sensor_frame():
    data = bvh.parse_bvh(figure_text(), 'figure.bvh')
    names = [[data.joints[i].name for i in m] for m in bvh.map_joints(data)]
    assert names[INDEX['torso']] == ['abdomen', 'chest']
    assert names[INDEX['left_knee']] == ['lShin']
    mot = motion.motion_from_bvh(data, height=1.7)
    pos = mot.positions
    # Standing height in file: head end (9+1+1+2+1+2 = 16) minus toe (0):
    # 16 units -> 1.7 m; floor (toe, y=0) at -1.0; head = mean of head
    # joint (14) and its end site (16).
    assert pos[0, INDEX['head'], 1] == pytest.approx(-1.0 + 15 / 16 * 1.7)
    assert pos[0, INDEX['left_foot'], 1] == pytest.approx(-1.0 + 1 / 16 * 1.7)
    # Mean torso (x, z) at (0, 2.5).
    np.testing.assert_allclose(pos[:, INDEX['torso'], 0].mean(), 0.0,
                               atol=1e-12)
    np.testing.assert_allclose(pos[:, INDEX['torso'], 2].mean(), 2.5)
    # The figure turns 90 degrees between frames; the mean left-hip
    # direction is put on the sensor's +x.
    span = pos[:, INDEX['left_hip']] - pos[:, INDEX['right_hip']]
    np.testing.assert_allclose(np.linalg.norm(span, axis=1), 2 * 1.7 / 16)
    mean_dir = span.mean(axis=0)
    assert mean_dir[0] > 0 and abs(mean_dir[2]) < 1e-9
    # Orientations: unit quaternions; frame 0 root identity up to the yaw.
    np.testing.assert_allclose(np.linalg.norm(mot.orientations, axis=2), 1.0)


def test_single_frame_clip_is_refused_naming_the_file():
    text = figure_text().replace('Frames: 2', 'Frames: 1')
    text = text[:text.rindex('0 9 0 90')]
    data = bvh.parse_bvh(text, 'one.bvh')
    with pytest.raises(bvh.BvhError, match='one.bvh: 1 frame of motion'):
        motion.motion_from_bvh(data)


def test_cmu_and_salsa_files_map():
    for name in ('cmu_60_01_salsa', 'cmu_131_01_walk'):
        path = os.path.join(MOCAP, name + '.bvh')
        if not os.path.exists(path):
            pytest.skip('shared mocap not available')
        mot = motion.load_motion(path)
        head = mot.positions[:, INDEX['head'], 1]
        feet = mot.positions[:, [INDEX['left_foot'], INDEX['right_foot']], 1]
        # A 1.70 m person: head centre about 1.5-1.65 m above the floor.
        assert 0.45 < np.median(head) < 0.7, name
        assert -1.0 < np.median(feet.min(axis=1)) < -0.85, name
        assert mot.rate == pytest.approx(120.0, rel=1e-3)
        left = mot.positions[:, INDEX['left_hip']] \
            - mot.positions[:, INDEX['right_hip']]
        assert left[:, 0].mean() > 0, name
