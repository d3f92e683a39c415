"""DPM processors: turn the samples of one capture window into a result.

No ROS.  A processor is named by class path in the DPM's ``~processor``
param; see ``Processor`` for the interface.  The DPM feeds a window's
samples to its processor one at a time, in stamp order, as they arrive
(``begin``, ``add``, ``result``), so the result is ready as soon as the
window is complete; ``process`` gives the same result for a whole
window at once (``verify_decisions`` recomputes recorded rounds with it).
"""

from __future__ import annotations

import importlib
import inspect
import math
from dataclasses import dataclass, field
from typing import Any, Optional

from hri_sync.wire.config import unknown, unknown_keys


@dataclass
class Frame:
    """One sample inside the capture window."""

    stamp: float        # global time, s
    msg: Any            # the message as received


@dataclass
class ProcessResult:
    """What a processor made of a window."""

    value: float
    frames_used: int
    frames_rejected: int = 0
    diagnostics: dict = field(default_factory=dict)
    # The value's noise floor as this window alone shows it (in the
    # value's unit): what the sensor's noise alone would give. NaN:
    # unknown (the processor cannot tell).
    noise_floor: float = math.nan
    # The window's coverage and dropped samples as the processor knows
    # them from its stream's own sample clock (an LSL stream's nominal
    # rate); NaN / None: the DPM's own, from the stamps' spacing.
    coverage: float = math.nan
    frames_dropped: Optional[int] = None


class Processor:
    """Base class of DPM processors.

    Override ``msg_type`` (the ROS type the DPM subscribes to) and
    ``topic`` (the relative name it subscribes to, in the client's
    namespace: remap it to the sensor's topic), maybe ``device_stamp``
    and ``check`` (validation at the boundary), and either
    ``process(frames, start, end)`` (a simple processor: the default
    ``add`` keeps the window's frames and ``result`` passes them to
    ``process``) or ``begin``, ``add`` and ``result`` (an incremental one,
    whose memory does not grow with the window; ``process`` then runs them
    over the frames).
    """

    msg_type = 'hri_sync/Sample'
    topic = 'samples'
    # True: ``device_stamp`` is on the DPM host's own clock (a bridge
    # mapped it there), so the clock model alone maps it to global time.
    host_stamped = False
    # True: the value is a level of activity (0: nothing happens), so the
    # lowest value this processor gives over short stretches of the
    # sensor's stream is a measure of its noise floor: the DPM then keeps
    # that quiet baseline (``hri_sync.data_process.noise_floor``). False (the
    # default): only the result's own ``noise_floor`` counts (NaN unless
    # the processor sets it).
    quiet_baseline = False

    def __init__(self, **params) -> None:
        if params:
            raise ValueError('%s takes no parameters, got %s'
                             % (type(self).__name__,
                                ', '.join(sorted(params))))

    def device_stamp(self, msg: Any) -> float | None:
        """The sample's own device time in s, or None to stamp at arrival."""
        return None

    def stamp_error(self, msg: Any) -> float:
        """The error bound (s) of the sample's device stamp itself,
        added to the clock model's (0: none known)."""
        return 0.0

    def check(self, msg: Any) -> None:
        """Validate one incoming message before it is stamped: raise
        ``hri_sync.wire.validate.Rejected`` (its ``reason`` is counted,
        per window and on /diagnostics) for one that must not be used."""

    def begin(self, start: float, end: float) -> None:
        """Start a window [start, end) (global s), forgetting the last."""
        self._window = (start, end)
        self._frames: list[Frame] = []

    def begin_quiet(self, start: float, end: float) -> None:
        """Start a stretch of the quiet baseline (``quiet_baseline``):
        only ``result().value`` is read, so a processor may skip the rest
        (its own noise floor, its diagnostics)."""
        self.begin(start, end)

    def add(self, frame: Frame) -> None:
        """Consume one Frame of the window (frames come in stamp order)."""
        self._frames.append(frame)

    def result(self) -> ProcessResult:
        """The ProcessResult of the frames added since ``begin``."""
        return self.process(self._frames, *self._window)

    def process(self, frames: list[Any], start: float,
                end: float) -> ProcessResult:
        """Return a ProcessResult for ``frames`` in [start, end)."""
        cls = type(self)
        if cls.add is Processor.add or cls.result is Processor.result:
            raise NotImplementedError(
                '%s implements neither process() nor add() and result()'
                % cls.__name__)
        return run_window(self, frames, start, end)


class WindowRun:
    """One window of a processor: frames in one at a time, one result out.

    A frame the processor raises on is rejected and counted (its
    ``frames_rejected`` and ``diagnostics['processor_errors']``, with the
    first error in ``diagnostics['processor_error']``); the window goes on.
    """

    def __init__(self, processor: Processor, start: float, end: float) -> None:
        self.processor = processor
        self.errors = 0
        self.first_error: str | None = None
        processor.begin(start, end)

    def add(self, frame: Frame) -> bool:
        """Give ``frame`` to the processor; False if it raised."""
        try:
            self.processor.add(frame)
        except Exception as e:  # a processor bug costs one frame, no more
            self.errors += 1
            if self.first_error is None:
                self.first_error = repr(e)
            return False
        return True

    def result(self) -> ProcessResult:
        """The processor's result with the rejected frames counted."""
        res = self.processor.result()
        if self.errors:
            diagnostics = dict(res.diagnostics, processor_errors=self.errors,
                               processor_error=self.first_error)
            res = ProcessResult(res.value, res.frames_used,
                                res.frames_rejected + self.errors,
                                diagnostics, res.noise_floor)
        return res


def stamp_order(frame: Frame) -> tuple[bool, int] | tuple[bool, float]:
    """Sort key: by stamp, non-finite stamps last."""
    return (not math.isfinite(frame.stamp), frame.stamp)


def run_window(processor: Processor, frames: list[Any], start: float,
               end: float) -> ProcessResult:
    """Feed ``frames`` (any order) to ``processor`` as one window."""
    run = WindowRun(processor, start, end)
    for frame in sorted(frames, key=stamp_order):
        run.add(frame)
    return run.result()


class CountMean(Processor):
    """Count and mean of a numeric stream (``hri_sync/Sample.value``).

    Non-finite values are rejected and counted.
    """

    def begin(self, start: float, end: float) -> None:
        self._sum, self._count, self._rejected = 0.0, 0, 0

    def add(self, frame: Frame) -> None:
        value = frame.msg.value
        if math.isfinite(value):
            self._sum += value
            self._count += 1
        else:
            self._rejected += 1

    def result(self) -> ProcessResult:
        mean = self._sum / self._count if self._count else math.nan
        return ProcessResult(value=mean, frames_used=self._count,
                             frames_rejected=self._rejected,
                             diagnostics={'count': self._count})


class DeviceStampedCountMean(CountMean):
    """CountMean of a sensor whose ``header.stamp`` is its own clock (as
    ``hri_sync/Sample`` documents it), for ``stamp_source: device``."""

    def device_stamp(self, msg: Any) -> float:
        return msg.header.stamp.to_sec()


# The stock processors (docs/sensors.md), offered for a misspelt path.
STOCK = (
    'hri_sync.data_process.processors.CountMean',
    'hri_sync.data_process.processors.DeviceStampedCountMean',
    'hri_sync.dance_off.expressiveness.SkeletonExpressiveness',
    'hri_sync.sensors.audio.AudioLevel',
    'hri_sync.sensors.generic.HeaderCount',
    'hri_sync.sensors.image.ImageMotion',
    'hri_sync.sensors.imu.ImuActivity',
    'hri_sync.sensors.joint_state.JointSpeed',
    'hri_sync.sensors.lsl.LslChannels',
)


def processor_class(path: str) -> type:
    """The Processor subclass at class path ``path``.

    Raises ValueError listing the valid names, with the nearest match,
    when the path cannot be imported or is not a Processor.
    """
    module_name, _, class_name = path.rpartition('.')
    try:
        module = importlib.import_module(module_name) if module_name \
            else None
    except ImportError:
        module = None
    if module is None:
        raise ValueError('~processor: ' + unknown(
            'processor', path, STOCK, lambda v: v.rpartition('.')[2]))
    cls = getattr(module, class_name, None)
    if not (isinstance(cls, type) and issubclass(cls, Processor)):
        names = [n for n, c in vars(module).items()
                 if isinstance(c, type) and issubclass(c, Processor)
                 and c is not Processor and c.__module__ == module.__name__]
        raise ValueError('~processor: ' + unknown(
            'processor in %s' % module_name, class_name, names))
    return cls


def load_processor(
        path: str,
        params: dict[str, Any] | None = None) -> Processor:
    """Instantiate the Processor subclass at class path ``path`` with
    ``params``.

    Raises ValueError listing the valid names (or keys), with the nearest
    match, for a path that is not a Processor or a key it does not take.
    """
    cls = processor_class(path)
    params = dict(params or {})
    sig = inspect.signature(cls)
    if not any(p.kind == p.VAR_KEYWORD for p in sig.parameters.values()):
        keys = list(sig.parameters)
        bad = unknown_keys('key of %s' % cls.__name__, params, keys)
        if bad:
            raise ValueError('~processor_params: ' + bad)
    try:
        return cls(**params)
    except TypeError as e:
        raise ValueError('~processor_params do not fit %s: %s' % (path, e))
