"""bench/fit_posture.py: the posture fitted on a motion, checked on its
halves, written into tracker profiles with their other lines kept."""
import json
import os
import subprocess
import sys

import numpy as np
import yaml

from hri_sync.fusion.profile import Profile
from test_fusion_posture import capture

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..')
SCRIPT = os.path.join(ROOT, 'bench', 'fit_posture.py')
sys.path.insert(0, os.path.join(ROOT, 'bench'))
import fit_posture as bench  # noqa: E402


def test_each_half_is_checked_on_a_posture_fitted_on_the_other():
    there_and_back = np.concatenate([capture(40), capture(40)[::-1]])
    errors, stated = bench.held_out(there_and_back, 0.03)
    assert len(errors) == len(stated) == 160     # both arms of each frame
    assert np.median(errors) < 0.01     # each half holds the other's poses
    assert (stated >= 0.03).all()
    # one way only: each half swings where the other never did
    onward, _ = bench.held_out(capture(80), 0.03)
    assert np.median(onward) > 0.05


def test_the_posture_goes_into_each_profile_its_other_lines_kept(tmp_path):
    text = '# the profile\nsigma: 0.05\n'
    paths = [tmp_path / 'a.yaml', tmp_path / 'b.yaml']
    for path in paths:
        path.write_text(text)
    motion = os.path.join(ROOT, 'data', 'motion', 'cmu_60_01_salsa.npz')
    for _ in range(2):                  # written again: still one block
        run = subprocess.run([sys.executable, SCRIPT, '--motion', motion,
                              '--profile'] + [str(p) for p in paths],
                             capture_output=True, text=True, check=True)
    printed = json.loads(run.stdout)
    assert printed['arms'] > 2000
    assert 0.02 < printed['held_out_error_m']['median'] < 0.15
    for path in paths:
        written = path.read_text()
        assert written.startswith(text)
        assert written.count('\nposture:') == 1
        profile = Profile.from_dict(yaml.safe_load(written))
        assert profile.sigma == 0.05
        assert len(profile.posture.hands) == printed['arms']
