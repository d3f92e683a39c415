"""bench/fit_offsets.py: the profile it writes (the package's, with the
motions' mean offsets and depth offsets), and the Kinect SDK profile in
config/ as it would write it, its posture fitted on the same recordings."""
import dataclasses
import functools
import importlib.util
import os
import sys

import numpy as np
import yaml

from hri_sync.fusion.profile import Profile

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..', '..')
SCRIPT = os.path.join(ROOT, 'bench', 'fit_offsets.py')
spec = importlib.util.spec_from_file_location('fit_offsets', SCRIPT)
bench = importlib.util.module_from_spec(spec)
spec.loader.exec_module(bench)
PROFILE = os.path.join(ROOT, 'config', 'fusion_depth_tracker.yaml')
SDK = os.path.join(ROOT, 'config', 'fusion_depth_tracker_kinect_sdk.yaml')
OTHER = ('offsets', 'depth')


@functools.lru_cache(maxsize=None)
def load(path):
    """A profile's YAML, read once (not to be changed)."""
    with open(path) as f:
        return yaml.load(f, Loader=yaml.CSafeLoader)


def rest(values, other=OTHER):
    """A profile's lines other than ``other`` (its offsets and depth
    offsets)."""
    return {k: v for k, v in values.items() if k not in other}


def test_the_profile_written_has_the_motions_mean_offsets(
        tmp_path, monkeypatch, capsys):
    base = Profile.from_dict(load(PROFILE))
    measured = {name: (dataclasses.replace(
        base, offsets=np.full((15, 3), 0.01 * k),
        depth=np.full(15, -0.02 * k)), 10 * k)
        for k, name in ((1, 'a.npz'), (2, 'b.npz'))}
    monkeypatch.setattr(bench, 'measured', lambda motion, views, b, cache:
                        measured[os.path.basename(motion)])
    out = tmp_path / 'sdk.yaml'
    monkeypatch.setattr(sys, 'argv', ['fit_offsets.py', '--motion', 'a.npz',
                                      'b.npz', '--out', str(out)])
    bench.main()
    written = load(str(out))
    assert np.allclose(written['offsets'], 0.015)
    assert np.allclose(written['depth'], -0.03)
    assert rest(written) == rest(load(PROFILE))
    assert 'bench/fit_offsets.py --motion a.npz b.npz' in out.read_text()
    report = yaml.safe_load(capsys.readouterr().out)
    assert report['exchanged_view_frames'] == {'a.npz': 10, 'b.npz': 20}
    assert np.allclose(report['offsets_before_m'], np.round(base.offsets, 4))


def test_the_kinect_sdk_profile_is_the_packages_with_other_offsets():
    # Refitting the package's profile (its error model) means writing
    # this one again: bench/fit_offsets.py, then bench/fit_posture.py on
    # the same recordings (docs/fusion.md).
    package, sdk = load(PROFILE), load(SDK)
    assert rest(sdk, OTHER + ('posture',)) == \
        rest(package, OTHER + ('posture',))
    assert not np.allclose(sdk['offsets'], package['offsets'], atol=0.01)
    assert sdk['posture']['arms'] != package['posture']['arms']
    with open(SDK) as f:
        assert 'fit_posture.py --motion data/motion/real/precog_Seq' in \
            f.read()
    Profile.from_dict(sdk)
