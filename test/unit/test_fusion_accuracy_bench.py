"""bench/fusion_accuracy.py: the split of the best view's hidden joints by
how many other views see them, and what a render is cached by."""
import importlib.util
import os
import types

import numpy as np

SCRIPT = os.path.join(os.path.dirname(os.path.abspath(__file__)), '..',
                      '..', 'bench', 'fusion_accuracy.py')
spec = importlib.util.spec_from_file_location('fusion_accuracy', SCRIPT)
bench = importlib.util.module_from_spec(spec)
spec.loader.exec_module(bench)

J = 15


class FixedTrack:
    """A view whose skeleton is the same at every instant."""

    def __init__(self, positions, confidence):
        self.sample = types.SimpleNamespace(
            positions=np.asarray(positions, float),
            confidence=np.asarray(confidence, float))

    def at(self, t, extrapolate):
        return self.sample


def frame(t, fused):
    body = types.SimpleNamespace(positions=np.asarray(fused, float))
    return types.SimpleNamespace(stamp=t, people=[
        types.SimpleNamespace(body=body)])


def test_a_best_view_that_hides_nothing_leaves_the_hidden_target_open():
    out = {'single_view_mean_m': {'front': 0.06, 'back': None},
           'best_view': 'front',
           'fused_mean_m': 0.045, 'best_view_hidden_mean_m': None,
           'fused_hidden_mean_m': None, 'slowest_pipeline_p95_ms': 90.0,
           'latency_p95_ms': 95.0, 'duplicate_people': 0,
           'bound_coverage': 0.99}
    t = bench.targets(out)
    assert t['hidden_40pct_below_best_view'] is None
    assert t['fused_20pct_below_best_view'] is True
    assert bench.mean_m([]) is None
    assert bench.mean_m([0.1, 0.2]) == 0.15
    out.update(best_view_hidden_mean_m=0.2, fused_hidden_mean_m=0.1)
    assert bench.targets(out)['hidden_40pct_below_best_view'] is True


def test_hidden_joints_are_grouped_by_the_views_that_see_them():
    truth = np.zeros((J, 3))
    off = np.zeros((J, 3))
    off[:, 0] = 0.1                      # every view 0.1 m off, but:
    best_conf = np.ones(J)
    best_conf[[7, 8, 9]] = 0.3           # the best view hides 3 joints
    a_conf = np.ones(J)
    a_conf[7] = 0.3                      # joint 7: seen by nobody else
    b_conf = np.ones(J)
    b_conf[[7, 8]] = 0.3                 # joint 8: seen by view a only
    a_pos = off.copy()
    a_pos[8, 0] = 0.25                   # ... and 0.25 m off there
    tracks = {'best': FixedTrack(off, best_conf),
              'a': FixedTrack(a_pos, a_conf),
              'b': FixedTrack(off, b_conf)}
    fused = np.zeros((J, 3))
    fused[:, 1] = 0.05                   # the fused body 0.05 m off
    frames = [frame(t, fused) for t in (0.0, 1 / 30)]
    out = bench.hidden_by_sight(bench.views_at(
        frames, lambda ts: [truth for _ in ts], tracks), 'best')
    third = round(1 / 3, 3)
    assert out['0'] == {'share': third, 'best_view_m': 0.1, 'fused_m': 0.05}
    assert out['1'] == {'share': third, 'best_view_m': 0.1, 'fused_m': 0.05,
                        'seeing_view_m': 0.25}
    assert out['2+'] == {'share': third, 'best_view_m': 0.1,
                         'fused_m': 0.05}


def test_an_instant_the_best_view_lacks_or_no_person_counts_nowhere():
    hidden = np.full(J, 0.3)
    tracks = {'best': FixedTrack(np.zeros((J, 3)), hidden)}
    tracks['best'].at = lambda t, e: None
    out = bench.hidden_by_sight(bench.views_at(
        [frame(0.0, np.zeros((J, 3)))], lambda ts: [np.zeros((J, 3))],
        tracks), 'best')
    assert all(g['share'] == 0 and g['fused_m'] is None
               for g in out.values())
    empty = types.SimpleNamespace(stamp=0.0, people=[])
    tracks = {'best': FixedTrack(np.zeros((J, 3)), hidden)}
    out = bench.hidden_by_sight(bench.views_at(
        [empty], lambda ts: [np.zeros((J, 3))], tracks), 'best')
    assert not any(g['share'] for g in out.values())


def test_the_best_view_and_the_fused_body_are_paired_on_its_instants():
    truth = np.zeros((J, 3))
    off = np.zeros((J, 3))
    off[:, 0] = 0.1                      # the best view 0.1 m off
    fused = np.zeros((J, 3))
    fused[:, 1] = 0.05                   # the fused body 0.05 m off ...
    worse = np.zeros((J, 3))
    worse[:, 1] = 0.4                    # ... but 0.4 m where it is alone
    tracks = {'best': FixedTrack(off, np.ones(J))}
    instants = bench.views_at([frame(0.0, fused), frame(1 / 30, fused)],
                              lambda ts: [truth for _ in ts], tracks)
    instants.append((frame(2 / 30, worse), truth, {'best': None}))
    out = bench.paired_with_best(instants, 'best')
    assert out == {'share': 0.667, 'best_view_m': 0.1, 'fused_m': 0.05}
    assert bench.paired_with_best(instants[2:], 'best') == {
        'share': 0.0, 'best_view_m': None, 'fused_m': None}


def test_a_clips_npz_and_track_are_rendered_apart():
    """The .track's times are rounded to 0.1 ms: another motion to the
    renderer, so another cache entry; the same file twice is one."""
    motion = os.path.join(os.path.dirname(SCRIPT), '..', 'data', 'motion',
                          'cmu_60_01_salsa')
    npz = bench.world_motion(bench.load_motion(motion + '.npz'))
    track = bench.world_motion(bench.load_motion(motion + '.track'))
    again = bench.world_motion(bench.load_motion(motion + '.npz'))
    assert bench.motion_id(npz) != bench.motion_id(track)
    assert bench.motion_id(npz) == bench.motion_id(again)


def test_a_view_that_never_tracked_the_person_has_no_error():
    from hri_sync.fusion.frames import SensorPose
    from hri_sync.fusion.profile import Profile
    n = 6
    truth = np.zeros((n, J, 3))
    seen = (np.ones(n, bool), np.full((n, J, 3), 0.1), truth, None)
    never = (np.zeros(n, bool), np.zeros((n, J, 3)), truth, None)
    fixed, raw = bench.single_view_errors(
        [seen, never], [SensorPose(0, 0, 0, 0)] * 2, Profile(),
        lambda t: np.zeros((len(t), J, 3)))
    assert np.isclose(raw[0], np.sqrt(3) * 0.1)
    assert np.isnan(fixed[1]) and np.isnan(raw[1])
    assert bench.per_view(['a', 'b'], fixed) == {
        'a': round(float(fixed[0]), 4), 'b': None}
