"""A client's noise floor: what its processor's value is when nothing moves.

No ROS.  Two measures, both on this client's own sensor, combined by the
DPM (``combine``) into the ``noise_floor`` of each ClientResult:

- the window's own estimate (``ProcessResult.noise_floor``; for the
  skeleton processor the white-jitter floor of
  ``hri_sync.dance_off.expressiveness.JitterFloor``): what the sensor's
  white noise alone adds, measured in the window whatever the person
  does;
- the quiet baseline (``QuietBaseline``, for processors whose value is a
  level of activity, ``Processor.quiet_baseline``): the processor is run
  over every ``chunk`` s stretch of the sensor's stream (a new stretch
  every ``step`` s, inside and outside capture windows), and the lowest
  value of the last ``span`` s is the level this sensor gives the
  quietest the scene has been.  It sees what the jitter estimate cannot:
  a tracker's smoothed (correlated) jitter and a standing person's sway.
  It assumes nothing about when the scene is quiet, only that it was at
  some moment of the span (between rounds, before the first).

The floor is the larger of the two: each is a lower bound of what a still
person would score on this sensor.

A calibration window (the CM's, before the first round, with nobody
moving) measures the quiet level directly: once one is in, its score
replaces the quiet baseline (``Calibration``), and the floor is
``NOISE_CALIBRATION``.  Without one the quiet baseline is the quietest
second the DPM saw, maybe a participant's pause: ``NOISE_UNCALIBRATED``
(``source``), which the decision module does not trust.
"""

from __future__ import annotations

import math
from collections import deque
from typing import Any, Callable

from hri_sync.data_process.processors import Frame, Processor
from hri_sync.wire.vocabulary import NoiseSource

DEFAULT_CHUNK = 1.0       # s
DEFAULT_STEP = 0.25       # s
DEFAULT_SPAN = 600.0      # s
MIN_FILL = 0.9             # share of a chunk its samples must span


class QuietBaseline:
    """The lowest value of a processor over short stretches of a stream.

    ``add(stamp, msg)`` every stamped sample (global s, in stamp order;
    an earlier one is ignored).  A stretch [k step, k step + chunk) is
    scored by a fresh processor from ``make_processor`` when a sample at
    or past its end arrives; it counts when its samples span at least
    ``MIN_FILL`` of it (a silent sensor's stretch does not) and its value
    is finite.  ``level()`` is (lowest value of the stretches that ended
    in the last ``span`` s, how many), (NaN, 0) before the first;
    ``in_window()`` whether that lowest stretch overlaps a capture window
    (``busy(start, end)``, when given, says so of a stretch).
    """

    def __init__(self, make_processor: Callable[[], Processor],
                 chunk: float = DEFAULT_CHUNK, step: float = DEFAULT_STEP,
                 span: float = DEFAULT_SPAN,
                 busy: Callable[[float, float], bool] | None = None) -> None:
        for name, v in (('chunk', chunk), ('step', step), ('span', span)):
            if not (math.isfinite(v) and v > 0):
                raise ValueError('noise floor %s must be > 0 s, got %r'
                                 % (name, v))
        self.make_processor = make_processor
        self.chunk, self.step, self.span = chunk, step, span
        # start -> [processor, first stamp, last stamp]
        self._open: dict[int, list[Any]] = {}
        # (end, value, in a capture window)
        self._values: deque[tuple[float, float, bool]] = deque()
        self.busy = busy or (lambda start, end: False)
        self._last = -math.inf
        self.errors = 0

    def add(self, stamp: float, msg: Any) -> None:
        if not (math.isfinite(stamp) and stamp > self._last):
            return
        self._last = stamp
        for k in [k for k in self._open
                  if k * self.step + self.chunk <= stamp]:
            self._finish(k)
        k = math.floor(stamp / self.step)
        if k not in self._open:
            try:
                p = self.make_processor()
                p.begin_quiet(k * self.step, k * self.step + self.chunk)
            except Exception:  # a processor bug costs the baseline a stretch
                self.errors += 1
            else:
                self._open[k] = [p, stamp, stamp]
        for k, c in list(self._open.items()):
            try:
                c[0].add(Frame(stamp, msg))
            except Exception:
                self.errors += 1
                del self._open[k]
                continue
            c[2] = stamp
        while self._values and self._values[0][0] < stamp - self.span:
            self._values.popleft()

    def _finish(self, k: int) -> None:
        p, first, last = self._open.pop(k)
        if last - first < MIN_FILL * self.chunk:
            return
        try:
            value = float(p.result().value)
        except Exception:
            self.errors += 1
            return
        if math.isfinite(value):
            start = k * self.step
            self._values.append((start + self.chunk, value,
                                 self.busy(start, start + self.chunk)))

    def level(self) -> tuple[float, int]:
        """(lowest value over the span, stretches it is the lowest of)."""
        if not self._values:
            return math.nan, 0
        return min(v[1] for v in self._values), len(self._values)

    def in_window(self) -> bool:
        """True when the lowest stretch of the span overlaps a capture
        window (False without stretches)."""
        if not self._values:
            return False
        return min(self._values, key=lambda v: v[1])[2]


class Calibration:
    """A DPM's calibration: the score of its last calibration window
    (global [start, end), nobody moving) with status ok, if any; or why
    the last one did not calibrate (``failed``)."""

    def __init__(self) -> None:
        self.level = math.nan
        self.start = self.end = math.nan
        self.failed = ''

    @property
    def done(self) -> bool:
        return valid_floor(self.level)

    def take(self, status_ok: bool, value: float, start: float,
             end: float, why: str = '') -> None:
        """A calibration window's result; one that is not ok, or whose
        value is not a finite number >= 0, keeps an earlier calibration
        and says why in ``failed``."""
        if status_ok and valid_floor(value):
            self.level, self.start, self.end = float(value), start, end
            self.failed = ''
        else:
            self.failed = why or 'its value %r is not a noise level' % (
                value,)

    def floor(self, own: float, quiet: float,
              has_baseline: bool) -> tuple[float, str]:
        """(noise floor, NoiseSource) of a window whose own estimate is
        ``own`` and whose quiet baseline is ``quiet`` (NaN: none yet;
        ``has_baseline`` False: the processor has none)."""
        if self.done and has_baseline:
            return combine(own, self.level), NoiseSource.NOISE_CALIBRATION
        floor = combine(own, quiet)
        if not valid_floor(floor):
            return floor, ''
        if has_baseline:
            return floor, NoiseSource.NOISE_UNCALIBRATED
        return floor, NoiseSource.NOISE_ESTIMATE


def valid_floor(x: Any) -> bool:
    """A usable noise floor: a finite number >= 0."""
    try:
        return math.isfinite(x) and x >= 0
    except TypeError:
        return False


def combine(*floors: float) -> float:
    """The largest of the usable floors (NaN when none is)."""
    known = [float(f) for f in floors if valid_floor(f)]
    return max(known) if known else math.nan
