"""hri_sync.fusion.feed (a recording through the fusion on the
recorder's clock) and hri_sync.fusion.settings (the settings by name)."""
import math
import types

import numpy as np
import pytest

from hri_sync.fusion.feed import (
    HOST_CLOCK, SKELETON, VIEW_CLOCK, VIEW_STATUS, Recorded, Replay,
    clock_model, stamp_uncertainty, to_global)
from hri_sync.fusion.frames import SensorPose
from hri_sync.fusion.pipeline import Fusion
from hri_sync.fusion.settings import NAMES, SETTINGS, fusion_params

POSES = {'a': SensorPose(3.0, 0.0, 1.0, math.pi),
         'b': SensorPose(0.0, 3.0, 1.0, -math.pi / 2)}
BODY = np.array([[0.1 * (j % 3), 0.2 * (j // 3) - 0.5, 0.0]
                 for j in range(15)])      # a body at the origin (world)
SPEED = np.array([0.1, 0.0, 0.0])          # m/s from global 100 s


def body_at(t):
    return BODY + SPEED * (t - 100.0)


def state(ok=True, offset=0.0, drift=0.0, local_ref=100.0,
          uncertainty=0.0):
    return types.SimpleNamespace(ok=ok, offset=offset, drift=drift,
                                 local_ref=local_ref,
                                 uncertainty=uncertainty)


def skeleton(view, stamp):
    pts = POSES[view].from_world(body_at(stamp))
    return types.SimpleNamespace(
        user_id=1, header=types.SimpleNamespace(
            stamp=types.SimpleNamespace(to_sec=lambda: stamp)),
        positions=[types.SimpleNamespace(x=p[0], y=p[1], z=p[2])
                   for p in pts], confidence=[0.9] * 15)


def recording(offset=0.0, latency=0.06, n=60, views=('a', 'b')):
    """Both views at 30 Hz from global 100 s, recorded ``latency`` s after
    capture on a clock ``offset`` s behind the global one."""
    out = [Recorded(100.0 - offset - 1, HOST_CLOCK,
                    data=state(offset=offset))]
    for k in range(n):
        for i, v in enumerate(views):
            stamp = 100.0 + k / 30 + 0.005 * i
            out.append(Recorded(stamp + latency - offset, SKELETON, v,
                                skeleton(v, stamp)))
    return sorted(out, key=lambda r: r.t)


def replay(**kw):
    return Replay(lambda clock: Fusion(POSES, fusion_params(
        lambda n, d: d), clock), **kw)


def test_a_clock_state_maps_host_time_both_ways():
    s = clock_model(state(offset=2.0, drift=1e-4, local_ref=50.0))
    g = to_global(60.0, s)
    assert g == pytest.approx(62.001)
    assert to_global(g, s, back=True) == pytest.approx(60.0)
    assert to_global(60.0, None) == 60.0
    assert to_global(60.0, clock_model(state(ok=False, offset=2.0))) == 60.0


def test_a_views_stamp_uncertainty_follows_its_clock_state():
    assert stamp_uncertainty(None, 0.001) == 0.001
    assert stamp_uncertainty(state(uncertainty=0.002), 0.001) \
        == pytest.approx(0.003)
    assert stamp_uncertainty(state(ok=False), 0.001) == math.inf
    # a forged or broken model is a lost one
    assert stamp_uncertainty(state(uncertainty=math.nan), 0.001) == math.inf
    assert stamp_uncertainty(state(uncertainty=-1.0), 0.001) == math.inf


@pytest.mark.parametrize('bad, field', [
    (dict(offset=math.nan), 'offset'), (dict(drift=0.5), 'drift'),
    (dict(uncertainty=-0.1), 'negative'), (dict(local_ref=-5.0), 'local_ref')])
def test_a_clock_state_with_no_usable_model_says_why(bad, field):
    with pytest.raises(ValueError, match=field):
        clock_model(state(**bad))
    assert clock_model(state()) is not None
    assert clock_model(state(ok=False, offset=math.nan)) is None


def test_a_recorded_host_clock_state_with_no_usable_model_is_left_out():
    records = recording(offset=0.3, n=30)
    records.insert(1, Recorded(records[0].t + 0.1, HOST_CLOCK,
                               data=state(offset=math.nan)))
    r = replay()
    frames = [f for s in r.run(records) for f in s.frames if f.people]
    assert r.bad_host_states == 1
    assert len(frames) >= 25 and r.host.offset == 0.3


@pytest.mark.parametrize('offset', [0.0, 0.3, -5.0])
def test_the_fused_instants_are_on_the_global_grid_after_their_captures(
        offset):
    r = replay()
    steps = list(r.run(recording(offset=offset)))
    frames = [f for s in steps for f in s.frames]
    stamps = np.array([f.stamp for f in frames if f.people])
    assert len(stamps) >= 55
    assert np.allclose(stamps * 30, np.round(stamps * 30))
    assert stamps.min() >= 100.0 - 1e-9
    for s in steps:
        for f in s.frames:
            for p in f.people:       # published after what it used came
                assert s.t + offset >= p.newest + 0.06 - 1e-9
                assert np.allclose(p.body.positions, body_at(f.stamp),
                                   atol=0.01)
    # every frame came out within the wait rule of its capture
    assert max(f.published - f.stamp for f in frames if f.people) < 0.2


def test_without_the_host_clock_state_a_clock_behind_rejects_the_views():
    records = [r for r in recording(offset=5.0) if r.kind != HOST_CLOCK]
    r = replay()
    frames = [f for s in r.run(records) for f in s.frames if f.people]
    assert not frames        # stamps 5 s ahead of the recorder's clock
    assert r.fusion.health['a'].rejected == {'future_stamp': 60}


def test_polls_follow_the_timer_grid_and_statuses_come_each_second():
    r = replay(poll_period=0.005, status_period=1.0)
    steps = list(r.run(recording(n=90)))
    due = [s.t for s in steps if s.status_due]
    assert np.allclose(np.diff(due), 1.0, atol=0.006)
    ended = [s for s in steps if s.ended]
    assert len(ended) == 1 and ended[0].t == pytest.approx(
        100.0 + 89 / 30 + 0.005 + 0.06)
    assert steps[-1].t <= ended[0].t + 1.0


def test_a_view_clock_lost_in_the_recording_is_named():
    records = recording(n=90)
    records.append(Recorded(101.0, VIEW_CLOCK, 'b', state(ok=False)))
    r = replay()
    list(r.run(sorted(records, key=lambda x: x.t)))
    assert r.fusion.health['b'].clock_lost()
    assert not r.fusion.health['a'].clock_lost()


def test_a_recorded_tracker_status_names_a_view_that_tracks_no_one():
    # View b's skeletons end at 101 s, its tracker saying it tracks no
    # one from then; a message of another type on its status topic is
    # counted, not read.
    records = [r for r in recording(n=90)
               if r.kind != SKELETON or r.view != 'b' or r.t < 101.0]
    said = 'not tracking: searching: no person-sized object in view'
    records += [Recorded(101.0 + k, VIEW_STATUS, 'b',
                         types.SimpleNamespace(level=1, message=said))
                for k in range(3)]
    records.append(Recorded(101.5, VIEW_STATUS, 'a', state()))
    r = replay()
    list(r.run(sorted(records, key=lambda x: x.t)))
    faults = r.fusion.faults()
    assert faults['b'] == [('not_tracking', 'its sensor: ' + said)]
    assert r.fusion.health['a'].rejected == {'bad_sensor_status': 1}


def test_records_out_of_order_and_unknown_kinds_are_refused():
    records = recording(n=3)
    with pytest.raises(ValueError, match='not in the order recorded'):
        list(replay().run(records[::-1]))
    with pytest.raises(ValueError, match='unknown record kind'):
        list(replay().run([Recorded(1.0, 'imu')]))


def test_settings_fill_fusion_params_and_name_a_bad_one():
    params = fusion_params(lambda n, d: {'stall_after': '0.8',
                                         'smooth_accel': 0,
                                         'arms_margin': math.inf}.get(n, d))
    assert params.health.stall_after == 0.8
    assert params.smooth.accel == 0.0
    assert params.arms.margin == math.inf
    assert params.sight.far == 4.5
    assert NAMES[0] == 'rate' and len(NAMES) == len(SETTINGS)
    with pytest.raises(ValueError, match=r'max_age=-1.0 is out of range'):
        fusion_params(lambda n, d: -1 if n == 'max_age' else d)
    with pytest.raises(ValueError, match=r"rate='fast' is not a number"):
        fusion_params(lambda n, d: 'fast' if n == 'rate' else d)
    with pytest.raises(ValueError,
                       match=r'depth_range=4.0 .* below max_range'):
        fusion_params(lambda n, d: 4.0 if n == 'depth_range' else d)
