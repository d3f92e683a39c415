"""A free-running 15-joint skeleton sensor replaying motion (no ROS).

The core of ``nodes/skeleton_sensor``. A sensor ticks at ``rate`` Hz on its
host clock with its own ``phase`` (s, within one period), so two sensors'
frames do not line up. The motion's timeline starts at a ``start`` instant
(host clock, set by the launch file), so two sensors replaying the two
partners of one take dance together. At a tick at host time t the sensor
shows the motion at clip time ``offset + (t - start) * speed`` (or the
fixed clip time ``hold``: a person standing still), plus Gaussian tracker
noise of ``noise`` m per axis (white: the worst case for a speed-based
score), and drops the frame with probability ``drop``.  ``pause(t0, t1)``
holds the person still over [t0, t1) (a calibration window): the clip
stops and goes on from the same pose at t1.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Iterator, Sequence, TYPE_CHECKING

import numpy as np

from hri_sync.dance_off.joints import NUM_JOINTS

if TYPE_CHECKING:
    from hri_sync.dance_off.motion import Motion


@dataclass
class SensorFrames:
    """Frames of one batch of ticks (dropped ticks removed)."""

    stamps: np.ndarray          # (M,) host time, s
    positions: np.ndarray       # (M, 15, 3) m, sensor frame
    orientations: np.ndarray    # (M, 15, 4) x, y, z, w
    confidence: np.ndarray      # (M, 15)
    dropped: int                # ticks dropped in this batch


def tick_times(start: float, phase: float, rate: float, t0: float,
               t1: float) -> np.ndarray:
    """Tick instants ``start + phase + k / rate`` (integer k) in [t0, t1)."""
    period = 1.0 / rate
    first = np.ceil((t0 - start - phase) / period - 1e-9)
    last = np.ceil((t1 - start - phase) / period - 1e-9)
    k = np.arange(first, last)
    return start + phase + k * period


class Perturbation:
    """A tracker's imperfections: white noise of ``noise`` m per axis on
    every joint and a probability ``drop`` of losing a frame, each from a
    seeded stream of its own (one draw per frame for drops, so a seed
    fixes which frames are dropped however they are batched)."""

    def __init__(self, noise: float = 0.003, drop: float = 0.0,
                 seed: int | None = None) -> None:
        if noise < 0 or not 0.0 <= drop < 1.0:
            raise ValueError('need noise >= 0, 0 <= drop < 1; got noise=%r '
                             'drop=%r' % (noise, drop))
        self.noise = float(noise)
        self.drop = float(drop)
        noise_seed, drop_seed = np.random.SeedSequence(seed).spawn(2)
        self.rng = np.random.default_rng(noise_seed)
        self.drop_rng = np.random.default_rng(drop_seed)

    def kept(self, count: int | tuple[int, ...]) -> np.ndarray:
        """Which of ``count`` frames survive (bool array)."""
        return self.drop_rng.random(count) >= self.drop

    def jitter(self, positions: np.ndarray) -> np.ndarray:
        """``positions`` (any shape, metres) with the noise added."""
        positions = np.asarray(positions, dtype=float)
        if self.noise > 0:
            return positions + self.rng.normal(0.0, self.noise,
                                               positions.shape)
        return positions


class SkeletonSource:
    """Samples a ``hri_sync.dance_off.motion.Motion`` like a live tracker."""

    def __init__(self, motion: Motion, noise: float = 0.003, drop: float = 0.0,
                 speed: float = 1.0, hold: float | None = None,
                 offset: float = 0.0, mode: str = 'pingpong',
                 confidence: float = 1.0, seed: int | None = None) -> None:
        if speed <= 0:
            raise ValueError('need speed > 0; got speed=%r' % (speed,))
        self.motion = motion
        self.perturb = Perturbation(noise, drop, seed)
        self.speed = float(speed)
        self.hold = hold
        self.offset = float(offset)
        self.mode = mode
        self.confidence = float(confidence)
        self.pauses: list[tuple[float, float]] = []   # host [t0, t1)

    def pause(self, t0: float, t1: float) -> None:
        """Stand still over host times [t0, t1): the clip shows its pose
        at t0 until t1, then goes on from it (two partners of a take,
        paused alike, stay together)."""
        if t1 > t0:
            self.pauses.append((float(t0), float(t1)))

    def restart(self, t: float) -> None:
        """Before the clip starts over at host time ``t`` (the caller's
        new start): the pauses before ``t`` no longer count."""
        self.pauses = [(max(a, t), b) for a, b in self.pauses if b > t]

    def clip_times(self, stamps: np.ndarray, start: float) -> np.ndarray:
        """Motion time shown at host times ``stamps``."""
        stamps = np.asarray(stamps, dtype=float)
        if self.hold is not None:
            return np.full(stamps.shape, float(self.hold))
        held = sum((np.clip(stamps - a, 0.0, b - a) for a, b in self.pauses),
                   np.zeros(stamps.shape))
        return self.offset + (stamps - start - held) * self.speed

    def frames(self, stamps: np.ndarray | list[float],
               start: float) -> SensorFrames:
        """The frames the sensor produces at ticks ``stamps`` (host time)."""
        ticks = np.asarray(stamps, dtype=float)
        keep = self.perturb.kept(ticks.shape)
        ticks = ticks[keep]
        clip = self.clip_times(ticks, start)
        pos = self.perturb.jitter(self.motion.positions_at(clip, self.mode))
        return SensorFrames(
            stamps=ticks, positions=pos,
            orientations=self.motion.orientations_at(clip, self.mode),
            confidence=np.full((len(ticks), NUM_JOINTS), self.confidence),
            dropped=int(np.sum(~keep)))


def recorded_frames(msgs: list[str],
                    device_secs: list[float]) -> tuple[list[str], np.ndarray]:
    """A recorded stream ready to replay: its frames in device-stamp order
    (stable), a frame whose stamp does not advance left out, and their
    times from 0.  Returns (frames, times)."""
    rel = np.asarray(device_secs, dtype=float)
    order = np.argsort(rel, kind='stable')
    msgs = [msgs[i] for i in order]
    rel = rel[order] - rel[order][0]
    keep = np.concatenate([[True], np.diff(rel) > 0])
    return [m for m, k in zip(msgs, keep) if k], rel[keep]


def replay_schedule(
        rel_times: Sequence[float]) -> Iterator[tuple[float, int]]:
    """Endless (time, index) of recorded frames replayed forward, backward,
    forward... ``rel_times``: the frames' increasing times from 0. The turn
    frames are not repeated, so the gaps are always recorded gaps."""
    rel = np.asarray(rel_times, dtype=float)
    if rel.ndim != 1 or len(rel) < 2 or not np.all(np.diff(rel) > 0):
        raise ValueError('need >= 2 recorded frames with increasing times')
    span = rel[-1] - rel[0]
    rel = rel - rel[0]
    count = len(rel)
    yield 0.0, 0
    turn = 0
    while True:
        base = turn * span
        if turn % 2 == 0:
            for i in range(1, count):
                yield base + rel[i], i
        else:
            for i in range(count - 2, -1, -1):
                yield base + span - rel[i], i
        turn += 1
