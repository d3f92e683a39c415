"""scripts/convert_mocap.py on small BVH files made here."""

import os
import subprocess
import sys

import numpy as np

from hri_sync.dance_off.joints import NUM_JOINTS
from hri_sync.dance_off.motion import load_motion
from test_bvh import TWO, figure_text

SCRIPT = os.path.join(os.path.dirname(__file__), '..', '..', 'scripts',
                      'convert_mocap.py')


def run(*args):
    return subprocess.run([sys.executable, SCRIPT] + list(args),
                          stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                          universal_newlines=True)


def test_converts_to_npz_and_track(tmp_path):
    src = tmp_path / 'fig.bvh'
    src.write_text(figure_text())
    out = tmp_path / 'motion'
    res = run(str(src), '--out', str(out), '--rate', '20', '--track', 'all')
    assert res.returncode == 0, res.stderr
    npz = load_motion(str(out / 'fig.npz'))
    track = load_motion(str(out / 'fig.track'))
    assert npz.positions.shape == (3, NUM_JOINTS, 3)    # 0.1 s at 20 Hz
    np.testing.assert_allclose(npz.positions, track.positions, atol=1e-4)
    assert 'mocap.cs.cmu.edu' in (out / 'fig.track').read_text()


def test_bad_file_is_named_and_fails(tmp_path):
    bad = tmp_path / 'two.bvh'
    bad.write_text(TWO % 'Zrotation Xrotation Yrotation')
    res = run(str(bad), '--out', str(tmp_path / 'motion'))
    assert res.returncode == 1
    assert str(bad) in res.stderr and 'lacks 15 of the 15' in res.stderr
    assert not (tmp_path / 'motion' / 'two.npz').exists()
