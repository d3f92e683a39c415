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
or the same stamp as an earlier frame is rejected and counted.
"""

from dataclasses import dataclass

import numpy as np

from hri_sync.dance_off.joints import NUM_JOINTS
from hri_sync.timing.processors import Processor, ProcessResult

DEFAULT_MIN_CONFIDENCE = 0.5


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


def expressiveness(stamps, positions, confidence=None, duration=None,
                   min_confidence=DEFAULT_MIN_CONFIDENCE):
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

    order = np.argsort(stamps, kind='stable')
    stamps, positions, confidence = \
        stamps[order], positions[order], confidence[order]
    good_stamp = np.isfinite(stamps)
    good_stamp[1:] &= stamps[1:] != stamps[:-1]

    finite = np.all(np.isfinite(positions), axis=2)
    confident = confidence >= min_confidence        # False for NaN too
    nonfinite = int(np.sum(~finite & good_stamp[:, None]))
    low_conf = int(np.sum(finite & ~confident & good_stamp[:, None]))
    valid = finite & confident & good_stamp[:, None]
    used = np.any(valid, axis=1)

    # For each (frame, joint): index of that joint's previous valid frame.
    rows = np.arange(count)[:, None]
    last = np.maximum.accumulate(np.where(valid, rows, -1), axis=0)
    prev = np.vstack([np.full((1, joints), -1), last[:-1]]) \
        if count else last
    pair = valid & (prev >= 0)

    safe = np.where(valid[..., None], positions, 0.0)
    prev_idx = np.maximum(prev, 0)
    prev_pos = np.take_along_axis(safe, prev_idx[..., None], axis=0)
    dist2 = np.sum((safe - prev_pos) ** 2, axis=2)
    dt = stamps[:, None] - np.where(pair, stamps[prev_idx], 0.0)
    total = float(np.sum(np.where(pair, dist2 / np.where(pair, dt, 1.0), 0.0)))

    if duration is None:
        duration = float(stamps[used][-1] - stamps[used][0]) \
            if np.any(used) else 0.0
    duration = float(duration)
    value = total / duration if duration > 0 else 0.0
    return Expressiveness(value=value, frames_used=int(np.sum(used)),
                          frames_rejected=int(count - np.sum(used)),
                          nonfinite_joints=nonfinite,
                          low_confidence_joints=low_conf,
                          terms=int(np.sum(pair)), duration=duration)


def _seconds(stamp):
    """A rospy.Time/Duration-like or a number, in seconds."""
    return stamp.to_sec() if hasattr(stamp, 'to_sec') else float(stamp)


class SkeletonExpressiveness(Processor):
    """DPM processor: expressiveness of a ``hri_sync/Skeleton`` stream.

    ``~processor_params``: ``min_confidence`` (default 0.5). T is the window
    (end - start), stamps are the frames' global stamps. A message without
    15 positions and 15 confidences is rejected as malformed.
    """

    msg_type = 'hri_sync/Skeleton'

    def __init__(self, min_confidence=DEFAULT_MIN_CONFIDENCE):
        super().__init__()
        self.min_confidence = float(min_confidence)

    def device_stamp(self, msg):
        return _seconds(msg.device_stamp)

    def process(self, frames, start, end):
        stamps, positions, confidence = [], [], []
        malformed = 0
        for frame in frames:
            try:
                pos = [(p.x, p.y, p.z) for p in frame.msg.positions]
                conf = [float(c) for c in frame.msg.confidence]
            except (AttributeError, TypeError, ValueError):
                malformed += 1
                continue
            if len(pos) != NUM_JOINTS or len(conf) != NUM_JOINTS:
                malformed += 1
                continue
            stamps.append(frame.stamp)
            positions.append(pos)
            confidence.append(conf)
        res = expressiveness(
            np.asarray(stamps, dtype=float),
            np.asarray(positions, dtype=float).reshape(-1, NUM_JOINTS, 3),
            np.asarray(confidence, dtype=float).reshape(-1, NUM_JOINTS),
            duration=end - start, min_confidence=self.min_confidence)
        return ProcessResult(
            value=res.value, frames_used=res.frames_used,
            frames_rejected=res.frames_rejected + malformed,
            diagnostics={'nonfinite_joints': res.nonfinite_joints,
                         'low_confidence_joints': res.low_confidence_joints,
                         'malformed_frames': malformed,
                         'terms': res.terms,
                         'min_confidence': self.min_confidence,
                         'T': res.duration})
