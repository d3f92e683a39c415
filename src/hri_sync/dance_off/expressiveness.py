"""The paper's expressiveness measure over a window of skeleton frames.

    expressiveness = sum over frames k and joints j of
                     speed_kj * distance_kj / T

where ``distance_kj`` is joint j's displacement (m) between its previous
usable frame and frame k, ``speed_kj`` that distance over the two frames'
time difference (from their own stamps, so a dropped frame widens the gap),
and T the window's duration in seconds. Each term is distance**2 / dt
(m^2/s), so the score is in m^2/s^2: the sum over joints of each joint's
mean squared speed over the window. Because T is in seconds, the score does
not depend on the sensor's frame rate; the paper's T counts frames, so at a
fixed rate r this value is the paper's value times r.

Joint samples below ``min_confidence`` or with a NaN/infinite coordinate
are left out (and counted); that joint's next usable sample is then paired
with its last usable one. A frame with no usable joint, a non-finite stamp
or the same stamp as an earlier frame is rejected and counted. A frame
whose usable joints are all exactly where they were (a tracker repeating
its last skeleton, as Kinect v1's SDK does) is no new measurement: it is
counted (``repeated``) and skipped, so the next new frame is paired with
the last new one over their real time difference.

The sum is kept as frames arrive (``RunningExpressiveness``): memory does
not grow with the window, and the score is ready with the window's last
frame.

The window's jitter floor (``JitterFloor``, ``Expressiveness.jitter``) is
what the sensor's white jitter alone adds to the score: human motion is
smooth from frame to frame, a tracker's white jitter is not, so each
joint's jitter sigma (per axis) is estimated robustly (1.4826 x the median
absolute value) from the second differences of its trajectory, and white
jitter of sigma adds 6 sigma**2 / dt to each of its displacement terms.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Sequence, TYPE_CHECKING

import numpy as np

from hri_sync.dance_off.joints import NUM_JOINTS
from hri_sync.dance_off.sensor_frames import SensorFrames
from hri_sync.people.participant import (PARTICIPANT, ParticipantSelector,
                                         Zone)
from hri_sync.data_process.processors import Processor, ProcessResult

if TYPE_CHECKING:
    from hri_sync.data_process.processors import Frame

DEFAULT_MIN_CONFIDENCE = 0.5
# |second difference| histogram of the jitter floor: log bins, 1e-6..1 m.
_JITTER_BINS = np.logspace(-6.0, 0.0, 241)
_MAD_TO_SIGMA = 1.4826      # a normal variable's sigma / its median |x|


@dataclass
class Expressiveness:
    """The score of one window and what went into it."""

    value: float                 # m^2/s^2 (see module docstring)
    frames_used: int             # frames with at least one usable joint
    frames_rejected: int         # frames that contributed nothing (see above)
    nonfinite_joints: int        # joint samples with a NaN/inf coordinate
    low_confidence_joints: int   # finite joint samples below min_confidence
    terms: int                   # joint displacements summed
    duration: float              # T, s
    # What white jitter alone adds to ``value`` (m^2/s^2, ``JitterFloor``);
    # NaN when no joint had three new samples in a row.
    jitter: float = math.nan


class JitterFloor:
    """The score white sensor jitter alone gives a window, from the window.

    For each joint, the second difference of three consecutive new samples
    (stamps t0 < t1 < t2, r = (t2 - t1) / (t1 - t0))
    ``z = ((x2 - x1) - r (x1 - x0)) / sqrt(1 + (1 + r)**2 + r**2)`` has,
    under white jitter of sigma per axis, the variance sigma**2 whatever
    the spacing; smooth human motion adds only its acceleration x dt**2.
    sigma_j = 1.4826 x the median |z| over the joint's axes and samples
    (a histogram of 20 log bins a decade: memory does not grow with the
    window), and each displacement term d**2/dt of the score gains
    6 sigma_j**2 / dt from the jitter: ``floor(T)`` is the sum over joints
    of 6 sigma_j**2 x (the sum of 1/dt over the joint's terms) / T.
    """

    def __init__(self, joints: int) -> None:
        self._hist = np.zeros((joints, len(_JITTER_BINS) + 1), dtype=np.int64)
        self._prev = np.zeros((joints, 3))       # the sample before the last
        self._prev_t = np.full(joints, math.nan)
        self._inv_dt = np.zeros(joints)          # sum of 1/dt of its terms

    def add(self, joints: np.ndarray, t: float, pos: np.ndarray,
            last_pos: np.ndarray, last_t: np.ndarray) -> None:
        """Joints ``joints`` (indices) have a new sample ``pos`` at ``t``
        paired with their last one (``last_pos``, ``last_t``)."""
        dt1 = t - last_t
        self._inv_dt[joints] += 1.0 / dt1
        t0 = self._prev_t[joints]
        three = np.isfinite(t0)
        if three.any():
            j = joints[three]
            r = dt1[three] / (last_t[three] - t0[three])
            z = ((pos[three] - last_pos[three])
                 - r[:, None] * (last_pos[three] - self._prev[j]))
            z /= np.sqrt(1.0 + (1.0 + r) ** 2 + r ** 2)[:, None]
            idx = np.searchsorted(_JITTER_BINS, np.abs(z))
            cols = self._hist.shape[1]
            self._hist += np.bincount(
                (j[:, None] * cols + idx).ravel(),
                minlength=self._hist.size).reshape(self._hist.shape)
        self._prev[joints] = last_pos
        self._prev_t[joints] = last_t

    def sigmas(self) -> np.ndarray:
        """Each joint's jitter sigma per axis, m (NaN: no estimate)."""
        out = np.full(len(self._hist), math.nan)
        centres = np.sqrt(_JITTER_BINS[1:] * _JITTER_BINS[:-1])
        for j, h in enumerate(self._hist):
            n = int(h.sum())
            if not n:
                continue
            k = int(np.searchsorted(np.cumsum(h), (n + 1) / 2.0))
            median = (0.0 if k == 0 else _JITTER_BINS[-1] if k > len(centres)
                      else centres[k - 1])
            out[j] = _MAD_TO_SIGMA * median
        return out

    def floor(self, duration: float) -> float:
        """The jitter floor over T = ``duration`` s, m^2/s^2 (NaN when no
        joint has an estimate)."""
        sigma = self.sigmas()
        known = np.isfinite(sigma)
        if not known.any() or not duration > 0:
            return math.nan
        return float(np.sum(6.0 * sigma[known] ** 2 * self._inv_dt[known])
                     / duration)


class RunningExpressiveness:
    """The expressiveness sum, one frame at a time, frames in stamp order.

    A frame stamped before the previous one cannot be paired in order: it
    is rejected and counted in ``out_of_order`` (sort the frames first).
    """

    def __init__(self, joints: int = NUM_JOINTS,
                 min_confidence: float = DEFAULT_MIN_CONFIDENCE,
                 jitter: bool = True) -> None:
        self.min_confidence = float(min_confidence)
        self._last_pos = np.zeros((joints, 3))
        self._last_t = np.zeros(joints)
        self._seen = np.zeros(joints, dtype=bool)
        self._all_seen = False
        self._prev = -math.inf      # stamp of the previous frame
        self.total = 0.0            # sum of distance**2 / dt, m^2/s
        self.frames_used = 0
        self.frames_rejected = 0
        self.nonfinite_joints = 0
        self.low_confidence_joints = 0
        self.terms = 0
        self.jitter = JitterFloor(joints) if jitter else None
        self._all = np.arange(joints)
        self.out_of_order = 0
        self.repeated = 0
        # first and last usable stamps
        self.first: float | None = None
        self.last: float | None = None

    def add(
            self, stamp: float, positions: np.ndarray,
            confidence: np.ndarray) -> bool:
        """Add one frame: ``positions`` (joints, 3) m, ``confidence``
        (joints,).  Returns whether it was used."""
        if not math.isfinite(stamp) or stamp <= self._prev:
            self.frames_rejected += 1
            if stamp < self._prev:
                self.out_of_order += 1
            return False
        self._prev = stamp
        if self._all_seen and np.isfinite(positions).all() and \
                (confidence >= self.min_confidence).all():
            return self._add_every(stamp, positions)
        finite = np.isfinite(positions).all(axis=1)
        valid = finite & (confidence >= self.min_confidence)  # NaN: False
        every = bool(valid.all())
        if not every:
            self.nonfinite_joints += int(np.count_nonzero(~finite))
            self.low_confidence_joints += int(np.count_nonzero(finite
                                                               & ~valid))
            if not valid.any():
                self.frames_rejected += 1
                return False
        if (self._all_seen or self._seen[valid].all()) and np.array_equal(
                positions[valid], self._last_pos[valid]):
            self.repeated += 1          # no new measurement: not paired
        elif every:                     # the common case, in fewer steps
            if self._all_seen:
                d2 = np.sum((positions - self._last_pos) ** 2, axis=1)
                self.total += float(np.sum(d2 / (stamp - self._last_t)))
                self.terms += len(valid)
                if self.jitter is not None:
                    self.jitter.add(self._all, stamp, positions,
                                    self._last_pos, self._last_t)
            else:
                self._pairs(valid, stamp, positions)
            self._last_pos[:] = positions
            self._last_t[:] = stamp
            self._seen[:] = True
            self._all_seen = True
        else:
            self._pairs(valid, stamp, positions)
            self._last_pos[valid] = positions[valid]
            self._last_t[valid] = stamp
            self._seen |= valid
            self._all_seen = bool(self._seen.all())
        self.frames_used += 1
        if self.first is None:
            self.first = stamp
        self.last = stamp
        return True

    def _add_every(self, stamp: float, positions: np.ndarray) -> bool:
        """``add`` of the common frame: every joint valid and seen before
        (the same sums as the general path, in fewer steps)."""
        diff = positions - self._last_pos
        if not diff.any():
            self.repeated += 1          # no new measurement: not paired
        else:
            d2 = np.sum(diff ** 2, axis=1)
            self.total += float(np.sum(d2 / (stamp - self._last_t)))
            self.terms += len(d2)
            if self.jitter is not None:
                self.jitter.add(self._all, stamp, positions, self._last_pos,
                                self._last_t)
            self._last_pos[:] = positions
            self._last_t[:] = stamp
        self.frames_used += 1
        self.last = stamp
        return True

    def _pairs(self, valid: np.ndarray, stamp: float,
               positions: np.ndarray) -> None:
        """Sum the terms of the valid joints seen before."""
        pair = valid & self._seen
        if pair.any():
            d2 = np.sum((positions[pair] - self._last_pos[pair]) ** 2, axis=1)
            self.total += float(np.sum(d2 / (stamp - self._last_t[pair])))
            self.terms += int(np.count_nonzero(pair))
            if self.jitter is not None:
                self.jitter.add(np.flatnonzero(pair), stamp,
                                positions[pair], self._last_pos[pair],
                                self._last_t[pair])

    def score(self, duration: float) -> Expressiveness:
        """The Expressiveness over T = ``duration`` s."""
        duration = float(duration)
        return Expressiveness(
            value=self.total / duration if duration > 0 else 0.0,
            frames_used=self.frames_used,
            frames_rejected=self.frames_rejected,
            nonfinite_joints=self.nonfinite_joints,
            low_confidence_joints=self.low_confidence_joints,
            terms=self.terms, duration=duration,
            jitter=math.nan if self.jitter is None
            else self.jitter.floor(duration))


def expressiveness(
        stamps: np.ndarray | list[float],
        positions: np.ndarray | list[np.ndarray],
        confidence: np.ndarray | None = None, duration: float | None = None,
        min_confidence: float = DEFAULT_MIN_CONFIDENCE) -> Expressiveness:
    """Score frames ``stamps`` (N,) s, ``positions`` (N, J, 3) m.

    ``confidence`` (N, J) in 0..1 (default: all 1). ``duration``: T in s
    (default: last minus first usable stamp). Frames need not be sorted.
    """
    stamps = np.asarray(stamps, dtype=float).reshape(-1)
    positions = np.asarray(positions, dtype=float)
    count = stamps.shape[0]
    if positions.ndim != 3 or positions.shape[0] != count \
            or positions.shape[2] != 3:
        raise ValueError('positions must be (%d, joints, 3), got %s'
                         % (count, positions.shape))
    joints = positions.shape[1]
    if confidence is None:
        confidence = np.ones((count, joints))
    confidence = np.asarray(confidence, dtype=float)
    if confidence.shape != (count, joints):
        raise ValueError('confidence must be (%d, %d), got %s'
                         % (count, joints, confidence.shape))
    run = RunningExpressiveness(joints, min_confidence)
    for k in np.argsort(stamps, kind='stable'):     # NaN stamps last
        run.add(float(stamps[k]), positions[k], confidence[k])
    if duration is None:
        duration = (run.last - run.first if run.frames_used
                    and run.first is not None and run.last is not None
                    else 0.0)
    return run.score(duration)


def _seconds(stamp: Any) -> float:
    """A rospy.Time/Duration-like, a rosbags Time (sec, nanosec, as a
    recording is read back) or a number, in seconds."""
    if hasattr(stamp, 'to_sec'):
        return stamp.to_sec()
    if hasattr(stamp, 'nanosec'):
        return stamp.sec + stamp.nanosec * 1e-9
    return float(stamp)


class SkeletonExpressiveness(Processor):
    """DPM processor: expressiveness of a ``hri_sync/Skeleton`` stream.

    ``~processor_params``: ``min_confidence`` (default 0.5);
    ``participant_zone`` ([x_min, x_max, z_min, z_max] m in the sensor's
    Skeleton frame, or empty: the whole view) and ``lost_after`` (s, 0.5):
    with several people on the topic only the participant's frames are
    scored (``hri_sync.people.participant``); the others' are rejected
    and counted (``bystander_frames``). With ``zone_sensor_pose`` ([x, y,
    z, yaw, pitch] of the sensor in world) the zone is [x_min, x_max,
    y_min, y_max] in the world frame. T is the window (end - start),
    stamps are the frames' global stamps. A message without 15 positions
    and 15 confidences is rejected as malformed. A tracker's frames are
    counted apart (``SensorFrames``: expected, published, skipped by a
    tracker that fell behind, unpublished) from its skeletons'
    ``frame_index`` and ``frames_skipped``. A fused body's frames name
    their views (Skeleton ``sources``, nodes/fusion): the result then names
    the views of its scored frames (diagnostics ``sources``) and how many
    scored frames each gave (``source_frames``, ``view:count ...``).
    Incremental: ``add`` updates the running sum, ``result`` reads it.
    """

    msg_type = 'hri_sync/Skeleton'
    topic = 'skeleton'
    quiet_baseline = True       # a still person's score is the floor

    def __init__(self, min_confidence: float = DEFAULT_MIN_CONFIDENCE,
                 participant_zone: str | Sequence[float] | None = None,
                 lost_after: float = 0.5,
                 zone_sensor_pose: str | Sequence[float] | None = None
                 ) -> None:
        super().__init__()
        self.min_confidence = float(min_confidence)
        self.zone = Zone.parse(participant_zone, zone_sensor_pose)
        self.lost_after = float(lost_after)
        self.begin(0.0, 0.0)

    def device_stamp(self, msg: Any) -> float:
        return _seconds(msg.device_stamp)

    def zone_params(self) -> dict[str, Any]:
        """The participant params as result diagnostics (text), from
        which ``params_from`` makes the same processor again."""
        z = self.zone
        return {'participant_zone': '' if z is None else '%r, %r, %r, %r' % (
                    z.x_min, z.x_max, z.z_min, z.z_max),
                'zone_sensor_pose': '' if z is None or z.sensor_pose is None
                else ', '.join(repr(v) for v in z.sensor_pose),
                'lost_after': self.lost_after}

    @staticmethod
    def params_from(diagnostics: dict[str, str]) -> dict[str, Any]:
        """Processor params from a result's diagnostics (a dict of
        text), defaults where they are not recorded."""
        d = diagnostics
        return {'min_confidence': float(d.get('min_confidence',
                                              DEFAULT_MIN_CONFIDENCE)),
                'participant_zone': d.get('participant_zone', ''),
                'zone_sensor_pose': d.get('zone_sensor_pose', ''),
                'lost_after': float(d.get('lost_after', 0.5))}

    def begin(self, start: float, end: float, jitter: bool = True) -> None:
        self._duration = end - start
        self._run = RunningExpressiveness(NUM_JOINTS, self.min_confidence,
                                          jitter)
        self._people = ParticipantSelector(self.zone, self.lost_after,
                                           start, end)
        self._malformed = 0
        self._sensor = SensorFrames()
        self._sources: dict[str, int] = {}

    def begin_quiet(self, start: float, end: float) -> None:
        """A quiet-baseline stretch: the score without the jitter floor."""
        self.begin(start, end, jitter=False)

    def add(self, frame: Frame) -> None:
        msg = frame.msg
        try:
            pos = np.array([(p.x, p.y, p.z) for p in msg.positions],
                           dtype=float)
            conf = np.array(msg.confidence, dtype=float)
            user = int(getattr(msg, 'user_id', 0))
            index = int(getattr(msg, 'frame_index', 0))
            skipped = int(getattr(msg, 'frames_skipped', 0))
            device = self.device_stamp(msg) if index > 0 else math.nan
        except (AttributeError, TypeError, ValueError):
            self._malformed += 1
            return
        if pos.shape != (NUM_JOINTS, 3) or conf.shape != (NUM_JOINTS,):
            self._malformed += 1
            return
        self._sensor.add(device, index, skipped)
        if self._people.offer(frame.stamp, user, pos) == PARTICIPANT:
            self._run.add(frame.stamp, pos, conf)
            for view in getattr(frame.msg, 'sources', ()):
                self._sources[view] = self._sources.get(view, 0) + 1

    def result(self) -> ProcessResult:
        res = self._run.score(self._duration)
        people = self._people.summary()
        diagnostics: dict[str, Any] = {
            'nonfinite_joints': res.nonfinite_joints,
            'low_confidence_joints': res.low_confidence_joints,
            'malformed_frames': self._malformed,
            'out_of_order_frames': self._run.out_of_order,
            'repeated_frames': self._run.repeated,
            'terms': res.terms,
            'noise_jitter': res.jitter,
            'min_confidence': self.min_confidence,
            'T': res.duration}
        diagnostics.update(self.zone_params())
        diagnostics.update(people)
        diagnostics.update(self._sensor.summary(self._duration))
        if self._sources:
            diagnostics['sources'] = ' '.join(sorted(self._sources))
            diagnostics['source_frames'] = ' '.join(
                '%s:%d' % v for v in sorted(self._sources.items()))
        return ProcessResult(
            value=res.value, frames_used=res.frames_used,
            frames_rejected=(res.frames_rejected + self._malformed
                             + people['bystander_frames']),
            diagnostics=diagnostics, noise_floor=res.jitter)
