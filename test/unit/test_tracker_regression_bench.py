"""bench/tracker_regression.py: tolerances, the worse-than-baseline check,
the table, and the baseline kept in the repo."""
import importlib.util
import json
import os

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__))))
_SPEC = importlib.util.spec_from_file_location(
    'tracker_regression',
    os.path.join(ROOT, 'bench', 'tracker_regression.py'))
bench = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(bench)
BASELINE = os.path.join(ROOT, 'test', 'data', 'tracker_accuracy.json')


def figures(mean=0.08, tracked=0.95, ghosts=0):
    return {'mean_error_m': mean, 'hands_p95_error_m': 0.4,
            'tracked_share': tracked, 'ghost_user_frames': ghosts,
            'ghost_users_per_minute': ghosts * 6.0, 'dropped_frames': 0}


def test_tolerance_is_two_spreads_or_the_floor():
    tol = bench.tolerances([figures(0.080), figures(0.082), figures(0.084)])
    assert abs(tol['mean_error_m'] - 2 * 0.002) < 1e-9
    assert tol['tracked_share'] == 0.005
    assert tol['ghost_user_frames'] == 0


def test_worse_beyond_tolerance_fails_better_or_within_passes():
    base = {'c/b': {'value': figures(),
                    'tolerance': {'mean_error_m': 0.003,
                                  'tracked_share': 0.01,
                                  'ghost_user_frames': 0}}}
    assert bench.compare(base, {'c/b': figures(mean=0.0829)}) == []
    assert bench.compare(base, {'c/b': figures(mean=0.05, tracked=0.99)}) \
        == []
    worse = bench.compare(base, {'c/b': figures(mean=0.0831, tracked=0.93,
                                                ghosts=1)})
    assert [w.split(':')[0] for w in worse] == [
        'c/b mean_error_m', 'c/b tracked_share', 'c/b ghost_user_frames']
    assert bench.compare(base, {}) == ['c/b: not run']


def test_the_baseline_covers_three_clips_by_two_bodies_untuned():
    with open(BASELINE) as f:
        baseline = json.load(f)
    cells = baseline['cells']
    assert sorted(cells) == sorted('%s/%s' % (c, b) for c in bench.CLIPS
                                   for b in bench.BODIES)
    assert len(bench.CLIPS) >= 3 and len(bench.BODIES) >= 2
    tuned = {'cmu_60_01_salsa', 'cmu_61_01_salsa'}
    assert not tuned & set(bench.CLIPS)
    for c in bench.CLIPS:
        assert os.path.exists(os.path.join(ROOT, 'data', 'motion',
                                           c + '.npz'))
    for cell in cells.values():
        assert set(bench.GATED) <= set(cell['tolerance'])
        assert cell['value']['ghost_user_frames'] == 0


def test_markdown_has_a_row_per_cell_and_the_hands_target():
    with open(BASELINE) as f:
        table = bench.markdown(json.load(f)).splitlines()
    assert 'target 0.25' in table[0]
    assert len(table) == 2 + len(bench.CLIPS) * len(bench.BODIES)
