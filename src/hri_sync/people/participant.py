"""Who the participant is when several people are in a sensor's view.

No ROS.  A tracker publishes every person it tracks (``hri_sync/Skeleton``
messages of different ``user_id`` on one topic).  ``ParticipantSelector``
chooses, frame by frame in stamp order, whose frames go into a window's
score; nothing is assumed from the user id:

- the participant is the person whose torso is inside the client's
  participant ``Zone`` (the whole view when there is no zone); when
  several are in it at once, the one first seen there stays;
- the participant is *lost* when its frames stop for ``lost_after`` s (a
  tracking loss) or its torso leaves the zone;
- a new user id where the participant was a moment ago (torsos within
  ``same_place`` m: two people cannot be that close) is the tracker
  re-identifying the participant: a *switch*, counted, with no loss;
- after a loss, the next person inside the zone continues the
  participant: a new user id there (the tracker re-identified the same
  person) is a *switch*, counted; the same id coming back is a *resume*;
- anyone else is a bystander: never scored, each frame counted; one who
  steps into the zone while the participant is there is an *intruder*,
  counted and reported (their frames are not scored either);
- a window in which nobody was ever in the zone has the participant
  *absent*; the seconds of the window without a participant are counted.
"""
import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

from hri_sync.dance_off.frames import SENSOR, rotation, skeleton_point
from hri_sync.dance_off.joints import INDEX

TORSO = INDEX['torso']

PARTICIPANT, BYSTANDER = 'participant', 'bystander'


@dataclass(frozen=True)
class Zone:
    """A floor rectangle, heights not limited: in the sensor's Skeleton
    frame (m: x to the sensor's right, z away from it) or, with
    ``sensor_pose``, in the world frame (REP 103: its x and y; the second
    pair of bounds is then y)."""

    x_min: float
    x_max: float
    z_min: float
    z_max: float
    # (x, y, z, yaw, pitch) of the sensor in world
    sensor_pose: Optional[tuple] = None

    def __post_init__(self):
        if self.sensor_pose is not None:
            pose = tuple(float(v) for v in self.sensor_pose)
            if len(pose) != 5 or not all(math.isfinite(v) for v in pose):
                raise ValueError('a sensor pose is [x, y, z, yaw, pitch] '
                                 '(m, rad), not %r' % (self.sensor_pose,))
            rot = rotation(pose[3], pose[4], SENSOR)
            object.__setattr__(self, 'sensor_pose', pose)
            object.__setattr__(self, '_rot', rot)
        values = (self.x_min, self.x_max, self.z_min, self.z_max)
        if not all(isinstance(v, (int, float)) and math.isfinite(v)
                   for v in values) or self.x_min >= self.x_max \
                or self.z_min >= self.z_max:
            raise ValueError('a participant zone is [x_min, x_max, z_min, '
                             'z_max] (m, finite, min < max), not %r'
                             % (values,))

    @classmethod
    def parse(cls, spec, sensor_pose=None):
        """A Zone from ``[x_min, x_max, z_min, z_max]`` (a list or a
        string of 4 numbers), None for an empty spec (no zone); with
        ``sensor_pose`` (a list or string of 5 numbers, or empty) in
        the world frame."""
        if spec is None or (isinstance(spec, str) and not spec.strip()) \
                or (isinstance(spec, (list, tuple)) and not spec):
            return None
        spec = numbers(spec)
        if len(spec) != 4:
            raise ValueError('a participant zone is [x_min, x_max, z_min, '
                             'z_max], not %r' % (spec,))
        pose = numbers(sensor_pose) if sensor_pose is not None else []
        return cls(*(float(v) for v in spec), sensor_pose=pose or None)

    def contains(self, p):
        """Whether Skeleton-frame point ``p`` (x, y, z; sensor frame) is
        in the zone (NaN: not)."""
        if self.sensor_pose is None:
            a, b = p[0], p[2]
        else:
            w = self._rot @ np.asarray(skeleton_point(p)) + \
                np.asarray(self.sensor_pose[:3])
            a, b = w[0], w[1]
        return bool(self.x_min <= a <= self.x_max
                    and self.z_min <= b <= self.z_max)


def numbers(spec):
    """A list of floats from a list or a string of numbers."""
    if isinstance(spec, str):
        try:
            return [float(v) for v in spec.replace('[', ' ').replace(
                ']', ' ').replace(',', ' ').split()]
        except ValueError:
            raise ValueError('%r is not a list of numbers' % spec)
    if len(spec) == 1 and isinstance(spec[0], (list, tuple)):
        spec = spec[0]
    return [float(v) for v in spec]


def body_point(positions):
    """Where a person is: the torso, or the mean of the finite joints
    when the torso is not tracked; None when no joint is."""
    p = np.asarray(positions, dtype=float)
    if np.isfinite(p[TORSO]).all():
        return p[TORSO]
    finite = np.isfinite(p).all(axis=1)
    return p[finite].mean(axis=0) if finite.any() else None


class ParticipantSelector:
    """Chooses the participant's frames in one window [start, end)."""

    def __init__(self, zone=None, lost_after=0.5, start=0.0, end=0.0,
                 same_place=0.25):
        if not lost_after > 0:
            raise ValueError('lost_after must be > 0 s, not %r' % lost_after)
        self.zone = zone
        self.lost_after = float(lost_after)
        self.same_place = float(same_place)
        self.where = None         # its last body point
        self.start, self.end = float(start), float(end)
        self.current = None       # user id followed, or None
        self.previous = None      # the last one followed
        self.last_seen = None     # stamp of its last frame
        self.since = None         # stamp it became the participant
        self.present = 0.0        # s with a participant
        self.ids = []             # user ids followed, in order
        self.events = []          # (s from start, what, user id)
        self.lost = self.switched = self.resumed = 0
        self.bystander_frames = 0
        self.intruders = set()

    def _inside(self, point):
        if point is None:
            return False
        return self.zone is None or self.zone.contains(point)

    def _event(self, stamp, what, user_id):
        self.events.append((stamp - self.start, what, user_id))

    def _lose(self, at, why):
        self.present += max(0.0, at - self.since)
        self._event(at, why, self.current)
        self.lost += 1
        self.previous, self.current = self.current, None

    def _follow(self, stamp, user_id):
        if self.previous is None:
            what = 'chosen'
        elif user_id == self.previous:
            what = 'resumed'
            self.resumed += 1
        else:
            what = 'switched'
            self.switched += 1
        self._event(stamp, what, user_id)
        self.current, self.since, self.last_seen = user_id, stamp, stamp
        if user_id not in self.ids:
            self.ids.append(user_id)

    def offer(self, stamp, user_id, positions):
        """One frame (stamps in order): PARTICIPANT or BYSTANDER."""
        point = body_point(positions)
        inside = self._inside(point)
        if self.current is not None and user_id != self.current \
                and stamp - self.last_seen > self.lost_after:
            self._lose(self.last_seen + self.lost_after, 'lost')
        if self.current is None:
            if inside:
                self._follow(stamp, user_id)
                self.where = point
                return PARTICIPANT
        elif user_id != self.current and inside and self.where is not None \
                and np.linalg.norm(point - self.where) < self.same_place:
            self.present += max(0.0, stamp - self.since)
            self.previous = self.current
            self._follow(stamp, user_id)
            self.where = point
            return PARTICIPANT
        elif user_id == self.current:
            # A frame without a usable joint stays the participant's (the
            # score counts it as rejected); one out of the zone is a leave.
            if inside or point is None:
                self.last_seen = stamp
                if point is not None:
                    self.where = point
                return PARTICIPANT
            self._lose(stamp, 'left_zone')
        elif inside:
            if user_id not in self.intruders:
                self.intruders.add(user_id)
                self._event(stamp, 'intruder', user_id)
        self.bystander_frames += 1
        return BYSTANDER

    def summary(self):
        """The window's participant record (a loss at its end included),
        as result diagnostics."""
        present = self.present
        if self.current is not None:
            if self.end - self.last_seen > self.lost_after:
                self._lose(self.last_seen + self.lost_after, 'lost')
                present = self.present
            else:
                present += self.end - self.since
        span = max(0.0, self.end - self.start)
        return {
            'participant': ('absent' if not self.ids else
                            ','.join(str(i) for i in self.ids)),
            'participant_lost': self.lost,
            'participant_switched': self.switched,
            'participant_resumed': self.resumed,
            'participant_absent_s': round(max(0.0, span - present), 3),
            'zone_intruders': len(self.intruders),
            'bystander_frames': self.bystander_frames,
            'participant_events': '; '.join(
                '%.3f s %s %s' % e for e in self.events) or 'none',
        }


def summary_text(diagnostics):
    """A one-line account of a result's participant record ('' without
    one), for logs and /diagnostics."""
    d = diagnostics
    if 'participant' not in d:
        return ''
    if d['participant'] == 'absent':
        return 'participant absent (%s bystander frames)' % \
            d['bystander_frames']
    return ('participant %s: lost %s, switched %s, resumed %s, absent %s s, '
            '%s intruders, %s bystander frames' % (
                d['participant'], d['participant_lost'],
                d['participant_switched'], d['participant_resumed'],
                d['participant_absent_s'], d['zone_intruders'],
                d['bystander_frames']))
