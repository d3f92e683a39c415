"""bench/tracker_views.py: the summary's height misses, mean errors and
facing, and the renders it tracks (every clip from every view, in the
view's frame)."""
import importlib.util
import os

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__))))
_SPEC = importlib.util.spec_from_file_location(
    'tracker_views', os.path.join(ROOT, 'bench', 'tracker_views.py'))
bench = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(bench)


def run(view, scene, height, error, facing_wrong=0.0):
    return {'clip': 'c', 'view': view, 'scene': scene, 'height_m': height,
            'body_height_m': 1.75, 'mean_error_m': error,
            'hands_p95_error_m': 0.4, 'tracked_share': 0.97,
            'facing_wrong_share': facing_wrong}


def test_summary_counts_heights_off_and_averages_by_view_and_scene():
    runs = [run('front', 'a', 1.70, 0.10), run('front', 'b', 1.55, 0.20),
            run('right', 'a', 1.30, 0.30, 0.25), run('right', 'b', 1.75, 0.12,
                                                      0.05)]
    s = bench.summary(runs)
    assert s['runs'] == 4
    assert s['height_off_8pct'] == 2       # 1.55 (11 % short) and 1.30
    assert s['height_off_15pct'] == 1      # 1.30 (26 % short)
    assert abs(s['mean_error_m'] - 0.18) < 1e-9
    assert s['mean_error_by_view_m'] == {'front': 0.15, 'right': 0.21}
    assert s['mean_error_by_scene_m'] == {'a': 0.2, 'b': 0.16}
    assert abs(s['facing_wrong_share'] - 0.075) < 1e-9
    assert s['facing_wrong_over_5pct'] == 1   # 5 % is not over 5 %


def test_every_view_sees_the_clip_from_its_own_pose(tmp_path):
    out = bench.tracks(['cmu_131_01_walk'], str(tmp_path))
    assert [v for _, v, _, _ in out] == [v[0] for v in bench.fusion.VIEWS]
    torsos = []
    for _, _, path, seconds in out:
        assert 0 < seconds <= bench.SECONDS
        rows = np.loadtxt(path)
        torsos.append(rows[0, 1 + 3 * 2:1 + 3 * 3])   # torso, sensor frame
    for (x, y, z) in torsos:                # the walker is before each view
        assert 1.0 < z < 6.0 and abs(x) < 3.0
    assert len({round(x, 2) for x, _, _ in torsos}) > 1   # different poses
