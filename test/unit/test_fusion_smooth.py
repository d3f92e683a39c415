"""hri_sync.fusion.smooth: a fused person's joints through a
constant-velocity Kalman filter: nearer the truth than the fused joints
on a moving, noisy body; a jump, a missing joint or a gap starts a joint
over; off at zero acceleration; in the fusion, a joint's bound moves with
it."""
import math

import numpy as np
import pytest

from hri_sync.dance_off.joints import NUM_JOINTS
from hri_sync.fusion.frames import SensorPose
from hri_sync.fusion.pipeline import Fusion, FusionParams
from hri_sync.fusion.smooth import SmoothParams, Smoother

RATE = 30.0


def moving(t):
    """Every joint swinging 0.3 m at 0.8 Hz (up to 1.5 m/s, 7.6 m/s^2)."""
    x = 0.3 * np.sin(2 * np.pi * 0.8 * t)
    return np.tile([x, 1.0, 0.5 * x], (NUM_JOINTS, 1))


def test_a_noisy_moving_body_comes_nearer_the_truth():
    rng = np.random.default_rng(36)
    smoother, raw, out = Smoother(), [], []
    sigma = np.full(NUM_JOINTS, 0.03)
    for k in range(300):
        t = k / RATE
        z = moving(t) + rng.normal(0, 0.03, (NUM_JOINTS, 3))
        x = smoother.update(t, z, sigma)
        if k >= 30:
            raw.append(np.linalg.norm(z - moving(t), axis=1).mean())
            out.append(np.linalg.norm(x - moving(t), axis=1).mean())
    assert np.mean(out) < 0.9 * np.mean(raw)      # 17 % nearer


def test_a_jump_a_missing_joint_and_a_gap_start_over():
    smoother = Smoother()
    sigma = np.full(NUM_JOINTS, 0.03)
    for k in range(30):
        smoother.update(k / RATE, moving(k / RATE), sigma)
    z = moving(1.0)
    z[7] += 0.6                 # a hand exchanged with the other
    z[8] = np.nan               # a hand no view gives
    x = smoother.update(1.0, z, sigma)
    assert np.allclose(x[7], z[7])
    assert np.isnan(x[8]).all()
    assert np.allclose(x[0], moving(1.0)[0], atol=0.02)
    later = moving(2.0) + 0.1
    assert np.allclose(smoother.update(2.0, later, sigma), later)


def test_off_at_zero_acceleration():
    z = moving(0.5)
    smoother = Smoother(SmoothParams(accel=0.0))
    smoother.update(0.0, moving(0.0), np.full(NUM_JOINTS, 0.03))
    assert smoother.update(0.5, z, np.full(NUM_JOINTS, 0.03)) is z


@pytest.mark.parametrize('accel', [10.0, 30.0])
def test_it_follows_a_joint_that_turns(accel):
    # No noise: the joint reverses at 7.6 m/s^2; the filter's lag keeps
    # it within 2 cm (1.6-1.7 cm at either acceleration).
    smoother = Smoother(SmoothParams(accel=accel))
    worst = 0.0
    for k in range(120):
        t = k / RATE
        x = smoother.update(t, moving(t), np.full(NUM_JOINTS, 0.03))
        worst = max(worst, np.linalg.norm(x - moving(t), axis=1).max())
    assert worst < 0.02


def fused_run(accel):
    """Two noisy views of a moving body through the fusion (smoothing at
    ``accel``; 0: off): each instant's (positions, bounds)."""
    poses = {'a': SensorPose(3.0, 0.0, 1.0, math.pi),
             'b': SensorPose(0.0, 3.0, 1.0, -math.pi / 2)}
    params = FusionParams()
    params.smooth.accel = accel
    now = [0.0]
    fusion = Fusion(poses, params, lambda: now[0])
    rng = np.random.default_rng(3)
    out = []
    for k in range(90):
        for v, pose in poses.items():
            t = 100.0 + k / 30
            now[0] = t + 0.05
            fusion.add(v, 1, t, pose.from_world(moving(t - 100.0))
                       + rng.normal(0, 0.02, (NUM_JOINTS, 3)),
                       np.full(NUM_JOINTS, 0.9), 0.001)
        out += [(p.body.positions, p.body.bound)
                for f in fusion.poll() for p in f.people]
    return out


def test_a_smoothed_joints_bound_moves_with_it():
    """The bound of a joint the filter moved is the fused joint's bound
    plus how far it moved: it holds whatever the fused one held."""
    plain, smoothed = fused_run(0.0), fused_run(30.0)
    assert len(plain) == len(smoothed) > 60
    moved = 0.0
    for (p0, b0), (p1, b1) in zip(plain, smoothed):
        shift = np.linalg.norm(p1 - p0, axis=1)
        assert np.allclose(b1, b0 + shift)
        moved = max(moved, shift.max())
    assert moved > 0.005
