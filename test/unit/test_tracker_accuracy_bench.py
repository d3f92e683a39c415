"""bench/tracker_accuracy.py's matrix: target judging, table, still track."""
import importlib.util
import os

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__))))
_SPEC = importlib.util.spec_from_file_location(
    'tracker_accuracy', os.path.join(ROOT, 'bench', 'tracker_accuracy.py'))
bench = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(bench)


def cell(scene='empty', mean=0.08, hands=0.2, tracked=0.95, fps=40.0,
         res='320x240'):
    return {'body': 'tall_slim', 'body_height_m': 1.93, 'scene': scene,
            'noise': 'kinect1', 'mean_error_m': mean,
            'hands_p95_error_m': hands,
            'tracked_share_after_calibration': tracked, 'fps': fps,
            'resolution': res}


def test_every_target_is_judged_and_bystander_errors_have_none():
    assert bench.judge(cell()) == {'mean_error': True, 'hands_p95': True,
                                   'tracked': True, 'fps': True}
    assert bench.judge(cell(mean=0.11, hands=0.26, tracked=0.89,
                            fps=29.0)) == {
        'mean_error': False, 'hands_p95': False, 'tracked': False,
        'fps': False}
    by = bench.judge(cell(scene='bystander', mean=0.5, hands=0.9))
    assert by['mean_error'] is None and by['hands_p95'] is None
    assert by['tracked'] is True
    assert bench.judge(cell(res='640x480', fps=10.0))['fps'] is None
    never = bench.judge(cell(mean=-1.0, hands=-1.0, tracked=0.0))
    assert never == {'mean_error': False, 'hands_p95': False,
                     'tracked': False, 'fps': True}


def test_markdown_reports_every_cell_met_or_not():
    cells = [cell(), cell(scene='wall_floor', mean=0.2)]
    for c in cells:
        c['met'] = bench.judge(c)
    cells.append(cell(mean=-1.0, hands=-1.0, tracked=0.0))
    table = bench.markdown({'cells': cells}).splitlines()
    assert len(table) == 5
    assert 'none (never tracked)' in table[4] and 'mean **no**' in table[4]
    assert 'mean yes' in table[2] and 'mean **no**' in table[3]
    assert '| tall_slim (1.93 m) | wall_floor | kinect1 | 0.200 |' in table[3]


def test_still_track_holds_the_first_pose(tmp_path):
    src = tmp_path / 'm.track'
    pose = ' '.join(str(0.1 * k) for k in range(45))
    src.write_text('# header\n0 %s\n0.5 %s\n' % (pose, ' '.join(
        '9' for _ in range(45))))
    path = bench.still_track(str(src), str(tmp_path), seconds=4.0)
    lines = [ln for ln in open(path) if not ln.startswith('#')]
    assert [ln.split()[0] for ln in lines] == ['0', '4']
    assert all(ln.split()[1:] == pose.split() for ln in lines)


def test_matrix_has_three_scenes_two_noises_and_three_bodies_or_more():
    assert [s for s, _ in bench.MATRIX_SCENES] == [
        'empty', 'wall_floor', 'bystander']
    assert [n for n, _ in bench.MATRIX_NOISE] == ['none', 'kinect1']
    assert len(bench.MATRIX_BODIES) >= 3
    assert os.path.exists(bench.WALK)
