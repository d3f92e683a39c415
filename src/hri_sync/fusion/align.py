"""One view's samples of one person, interpolated to common instants.

Samples carry their global capture time; a common instant between two
samples is reached by linear interpolation of each joint (never by
rounding to a period), a little past the newest sample by extrapolation
along the last two. A joint missing (NaN) at either end is missing.
"""

from __future__ import annotations

import bisect
from dataclasses import dataclass
from typing import List, Optional

import numpy as np


@dataclass
class Sample:
    """One skeleton of one view, in world."""

    stamp: float                # s, global time of the body it shows
    positions: np.ndarray       # (15, 3) world, NaN: missing
    confidence: np.ndarray      # (15,) 0..1
    uncertainty: float          # s, 95 % bound of the stamp's error
    captured: Optional[float] = None    # s, global capture time (the
                                        # stamp before a tracker's delay
                                        # is taken off); None: stamp

    def capture(self) -> float:
        """Global capture time (s)."""
        return self.stamp if self.captured is None else self.captured


@dataclass
class Aligned:
    """A view's skeleton at a common instant."""

    positions: np.ndarray       # (15, 3)
    confidence: np.ndarray      # (15,)
    speed: np.ndarray           # (15,) m/s, 0 where unknown
    uncertainty: float          # s
    newest: float               # capture time of the newest sample used


class Track:
    """The samples of one (view, user), in stamp order."""

    def __init__(self, keep: float = 2.0, max_gap: float = 0.25) -> None:
        self.keep = keep
        self.max_gap = max_gap
        self.samples: List[Sample] = []

    @property
    def newest(self) -> float:
        """Stamp of the newest sample (-inf when empty)."""
        return self.samples[-1].stamp if self.samples else -np.inf

    def unbroken_since(self, gap: Optional[float] = None) -> float:
        """Stamp of the first sample kept of the newest run with no gap
        over ``gap`` s (None: ``max_gap``; inf when empty)."""
        gap = self.max_gap if gap is None else gap
        s = self.samples
        i = len(s) - 1
        while i > 0 and s[i].stamp - s[i - 1].stamp <= gap:
            i -= 1
        return s[i].stamp if s else np.inf

    def add(self, sample: Sample) -> bool:
        """Insert in stamp order; False for a repeated stamp."""
        stamps = [s.stamp for s in self.samples]
        i = bisect.bisect_left(stamps, sample.stamp)
        if i < len(stamps) and stamps[i] == sample.stamp:
            return False
        self.samples.insert(i, sample)
        while self.samples and \
                self.samples[0].stamp < sample.stamp - self.keep:
            self.samples.pop(0)
        return True

    def at(self, t: float, max_extrapolation: float = 0.0
           ) -> Optional[Aligned]:
        """The skeleton at ``t``, or None outside the samples (plus
        ``max_extrapolation`` s after the newest) or across a gap."""
        s = self.samples
        if not s or t < s[0].stamp or t > s[-1].stamp + max_extrapolation:
            return None
        if len(s) == 1:
            if t != s[0].stamp:
                return None
            return Aligned(s[0].positions.copy(), s[0].confidence.copy(),
                           np.zeros(len(s[0].confidence)),
                           s[0].uncertainty, s[0].capture())
        i = bisect.bisect_right([x.stamp for x in s], t)
        a, b = (s[i - 1], s[i]) if i < len(s) else (s[-2], s[-1])
        if b.stamp - a.stamp > self.max_gap:
            return None
        return _between(a, b, t)


def _between(a: Sample, b: Sample, t: float) -> Aligned:
    """Linear interpolation (or extrapolation past ``b``) at ``t``."""
    dt = b.stamp - a.stamp
    w = (t - a.stamp) / dt
    positions = a.positions + w * (b.positions - a.positions)
    speed = np.linalg.norm(b.positions - a.positions, axis=1) / dt
    confidence = np.minimum(a.confidence, b.confidence)
    missing = ~np.isfinite(positions).all(axis=1)
    positions[missing] = np.nan
    confidence[missing] = 0.0
    speed[missing] = 0.0
    newest = b.capture() if t > a.stamp else a.capture()
    return Aligned(positions, confidence, speed,
                   max(a.uncertainty, b.uncertainty), newest)
