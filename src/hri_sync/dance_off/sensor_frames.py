"""A depth tracker's frames over a capture window: expected, published,
skipped.

A tracker (``skeleton_tracker``) publishes a skeleton only for the frames it
tracked, and a tracker that falls behind real time (starved of CPU) reads
only its sensor's newest frame: the frames in between it never processes.
Its skeletons carry the sensor's ``frame_index`` and the running count of
frames it skipped, ``frames_skipped`` (``hri_sync/Skeleton``), so a window
tells the frames the sensor made apart:

- ``frames_expected``: the window's duration times the sensor's frame rate
  (the rate from the frame indices and device stamps of the skeletons);
- ``frames_published``: frames with at least one skeleton (any user);
- ``frames_skipped``: frames the tracker never processed, from the first to
  the last frame published in the window (the growth of its count, at most
  the frames between two published ones' indices: a count that grew more,
  as when the sensor switched streams, is not the window's);
- ``frames_unpublished``: the rest, ``frames_expected - frames_published -
  frames_skipped`` (at least 0): frames it processed and did not publish
  (searching, calibrating, no clock), and the window's frames before its
  first and after its last published one, whether skipped or not.

Skeletons without a frame index (0: a replayed or older sensor) are not
counted; without two frames of known index and stamp the rate, and so
``frames_expected`` and ``frames_unpublished``, are NaN.  A frame index that
goes back (the sensor reopened, a recording looping) starts a new stretch,
unless the frame is one the stretch has not had, between two it has, and
its count of skipped frames lies between theirs: then it is a frame of the
stretch that came after later ones (stamp order, when the device clock map
moved between them, either way), counted as published and not as a
restart (which would count the frames after it twice); a count that goes
back (the tracker restarted) counts from its new value.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field


@dataclass
class _Stretch:
    """Frames of increasing index: the first and last (index, device s)."""

    first_index: int
    first_device: float
    last_index: int
    last_device: float
    counts: dict[int, int] = field(default_factory=dict)   # index: skipped

    def holds_late(self, index: int, skipped: int) -> bool:
        """Whether frame ``index`` with count ``skipped`` is one of the
        stretch's that came late: one it has not had, between two it has,
        its count between theirs."""
        if not self.first_index < index < self.last_index \
                or index in self.counts:
            return False
        seen = sorted(self.counts)
        k = bisect.bisect(seen, index)
        return self.counts[seen[k - 1]] <= skipped <= self.counts[seen[k]]

    def rate(self) -> float:
        """Frames per second over the stretch (NaN: one frame)."""
        span = self.last_device - self.first_device
        if self.last_index <= self.first_index or not span > 0:
            return math.nan
        return (self.last_index - self.first_index) / span


class SensorFrames:
    """Counts a tracker's frames over one window (see the module doc)."""

    def __init__(self) -> None:
        self.published = 0
        self.skipped = 0
        self._stretches: list[_Stretch] = []
        self._count: int | None = None   # the last frame's frames_skipped

    def add(self, device: float, index: int, skipped: int) -> None:
        """A skeleton of frame ``index`` (0: unknown) at device time
        ``device`` s, the tracker's ``skipped`` count then; in stamp
        order, several users' skeletons of a frame alike."""
        if index <= 0 or not math.isfinite(device):
            return
        last = self._stretches[-1] if self._stretches else None
        if last is not None and index == last.last_index:
            return                       # another user of the same frame
        if last is not None and last.holds_late(index, skipped):
            last.counts[index] = skipped
            self.published += 1          # a frame of the stretch, late
            return
        if last is None or index < last.last_index:
            between = index - 1          # a new stretch: frames before it
            last = _Stretch(index, device, index, device)
            self._stretches.append(last)
        else:
            between = index - last.last_index - 1
            last.last_index, last.last_device = index, device
        last.counts[index] = skipped
        self.published += 1
        if self._count is not None:
            grown = (skipped - self._count if skipped >= self._count
                     else skipped)
            self.skipped += min(grown, between)
        self._count = skipped

    def rate(self) -> float:
        """The sensor's frame rate, Hz: that of the stretch spanning the
        most frames (NaN: unknown)."""
        best = max(self._stretches, default=None,
                   key=lambda s: s.last_index - s.first_index)
        return best.rate() if best is not None else math.nan

    def summary(self, duration: float) -> dict[str, float]:
        """The counts of a window of ``duration`` s (the module doc)."""
        rate = self.rate()
        expected = (float(round(duration * rate)) if math.isfinite(rate)
                    else math.nan)
        return {'frames_expected': expected,
                'frames_published': self.published,
                'frames_skipped': self.skipped,
                'frames_unpublished': max(
                    0.0, expected - self.published - self.skipped)
                if math.isfinite(expected) else math.nan,
                'sensor_rate': rate}
