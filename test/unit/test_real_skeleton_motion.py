"""scripts/real_skeleton_motion.py: a real Kinect recording as a motion
the virtual Kinect renders, its feet on the floor."""
import os
import subprocess
import sys

import numpy as np

from hri_sync.dance_off.joints import INDEX
from hri_sync.dance_off.motion import load_motion
from hri_sync.people.joint_maps import KINECT_V1

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..',
                      '..', 'scripts', 'real_skeleton_motion.py')


def precog_csv(path, frames=4, camera_height=0.8, untracked=(),
               toes=(0.0, 0.0)):
    """A PRECOG-style CSV of a person 3 m in front of a Kinect
    ``camera_height`` m up, stepping 1 cm to the side each frame; the
    ``untracked`` frames all 0 0 0 (the sensor's no one); the SDK's foot
    joints ``toes`` (ahead, down) m from the ankles."""
    rows = ['; '.join(KINECT_V1)]
    for k in range(frames):
        joints = []
        for n, name in enumerate(KINECT_V1):
            if k in untracked:
                joints.append('0 0 0')
                continue
            y = -camera_height if ('Foot' in name or 'Ankle' in name) \
                else 0.5 - 0.05 * n
            z = 3.0
            if 'Foot' in name:
                z, y = z - toes[0], y - toes[1]
            joints.append('%f %f %f' % (0.01 * k + 0.01 * n, y, z))
        rows.append(';'.join(joints) + ';punch')
    path.write_text('\n'.join(rows) + '\n')


def convert(csv, out, refused=None):
    """The script run on ``csv``; with ``refused``, it fails with that
    message on stderr and writes no ``out``."""
    run = subprocess.run([sys.executable, SCRIPT, str(csv), '--out',
                          str(out)], capture_output=True, text=True,
                         check=refused is None)
    if refused is not None:
        assert run.returncode != 0
        assert refused in run.stderr
        assert not out.exists()
    return run


def test_a_recording_becomes_a_motion_with_its_feet_on_the_floor(tmp_path):
    csv, out = tmp_path / 'Seq9_9.csv', tmp_path / 'seq.npz'
    precog_csv(csv)
    run = convert(csv, out)
    assert '4 frames' in run.stdout and '100 % of the joints' in run.stdout
    motion = load_motion(str(out))
    assert np.allclose(motion.times, np.arange(4) / 30.0)
    feet = motion.positions[:, [INDEX['left_foot'], INDEX['right_foot']], 1]
    assert np.isclose(np.median(feet), -0.949, atol=1e-3)
    # the sidestep survives, 1 cm a frame
    torso = motion.positions[:, INDEX['torso']]
    assert np.allclose(np.abs(np.diff(torso[:, 0])), 0.01, atol=1e-3)


def test_each_foot_is_put_on_its_shin_below_the_ankle(tmp_path):
    # The SDK's foot 7 cm ahead of the ankle (towards the sensor) and 6 cm
    # down; the shins from the knees (0.65 and 0.45 m above) nearly upright.
    csv, out = tmp_path / 'Seq9_6.csv', tmp_path / 'seq.npz'
    precog_csv(csv, toes=(0.07, 0.06))
    convert(csv, out)
    p = load_motion(str(out)).positions
    for knee, foot, above in (('left_knee', 'left_foot', 0.65),
                              ('right_knee', 'right_foot', 0.45)):
        assert np.allclose(p[:, INDEX[foot], 2], 3.0, atol=1e-3)
        shin = np.linalg.norm(p[:, INDEX[foot]] - p[:, INDEX[knee]], axis=1)
        assert np.allclose(shin, np.hypot(above, 0.01) + 0.06, atol=1e-3)


def test_the_torso_is_put_midway_between_the_hips_and_the_neck(tmp_path):
    # The CSV's SDK Spine lies 5 cm above its ShoulderCenter (the neck).
    csv, out = tmp_path / 'Seq9_5.csv', tmp_path / 'seq.npz'
    precog_csv(csv)
    convert(csv, out)
    p = load_motion(str(out)).positions
    hips = (p[:, INDEX['left_hip']] + p[:, INDEX['right_hip']]) / 2
    assert np.allclose(p[:, INDEX['torso']], (hips + p[:, INDEX['neck']]) / 2,
                       atol=1e-3)
    above_neck = p[:, INDEX['torso'], 1] - p[:, INDEX['neck'], 1]
    assert (above_neck < 0).all()


def test_a_file_that_is_not_a_kinect_recording_is_refused(tmp_path):
    bad = tmp_path / 'bad.csv'
    bad.write_text('a;b;c\n1 2 3;4 5 6;7 8 9\n')
    convert(bad, tmp_path / 'x.npz', refused='not a Kinect v1 joint file')


def test_frames_without_a_person_are_left_out_and_none_is_refused(tmp_path):
    csv, out = tmp_path / 'Seq9_8.csv', tmp_path / 'seq.npz'
    precog_csv(csv, frames=5, untracked=(0, 3))
    run = convert(csv, out)
    assert '3 frames' in run.stdout and '60 % of the joints' in run.stdout
    motion = load_motion(str(out))
    assert np.allclose(motion.times, np.array([1, 2, 4]) / 30.0)
    assert np.isfinite(motion.positions).all()
    empty = tmp_path / 'Seq9_7.csv'
    precog_csv(empty, frames=3, untracked=(0, 1, 2))
    convert(empty, tmp_path / 'x.npz', refused='no frame gives every joint')
