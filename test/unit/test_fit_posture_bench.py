"""bench/fit_posture.py: the posture fitted on motions, each checked on
the others (one motion: its halves), written into tracker profiles with
their other lines kept."""
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


def test_each_part_is_checked_on_a_posture_fitted_on_the_others():
    there, back = capture(40), capture(40)[::-1]
    checked = bench.held_out([there, back], 0.03)
    assert [len(e) for e, _ in checked] == [80, 80]  # both arms a frame
    errors, stated = np.concatenate(checked, axis=1)
    assert np.median(errors) < 0.01     # each part holds the other's poses
    assert (stated >= 0.03).all()
    # one way only: each half swings where the other never did
    onward = capture(80)
    (first, _), (second, _) = bench.held_out([onward[:40], onward[40:]],
                                             0.03)
    assert np.median(first) > 0.05 and np.median(second) > 0.05


def test_the_posture_goes_into_each_profile_its_other_lines_kept(tmp_path):
    text = '# the profile\nsigma: 0.05\n'
    paths = [tmp_path / 'a.yaml', tmp_path / 'b.yaml']
    for path in paths:
        path.write_text(text)
    motions = [os.path.join(ROOT, 'data', 'motion', name) for name in
               ('cmu_60_01_salsa.npz', 'cmu_61_01_salsa.npz')]
    for k in (1, 2):                    # written again: still one block
        run = subprocess.run([sys.executable, SCRIPT, '--motion']
                             + motions[:k] + ['--profile']
                             + [str(p) for p in paths],
                             capture_output=True, text=True, check=True)
        printed = json.loads(run.stdout)
        assert printed['arms'] > 2000
        assert 0.02 < printed['held_out_error_m']['median'] < 0.15
        # one motion: its halves; two: each from the other
        assert sorted(printed.get('held_out_error_by_motion_m', ())) == (
            [] if k == 1 else ['cmu_60_01_salsa.npz', 'cmu_61_01_salsa.npz'])
    for path in paths:
        written = path.read_text()
        assert written.startswith(text)
        assert written.count('\nposture:') == 1
        profile = Profile.from_dict(yaml.safe_load(written))
        assert profile.sigma == 0.05
        assert len(profile.posture.hands) == printed['arms']
