"""DPM processors: turn the samples of one capture window into a result.

No ROS.  A processor is named by class path in the DPM's ``~processor``
param; see ``Processor`` for the interface.
"""
import importlib
import math
from dataclasses import dataclass, field


@dataclass
class Frame:
    """One sample inside the capture window."""

    stamp: float        # global time, s
    msg: object         # the message as received


@dataclass
class ProcessResult:
    """What a processor made of a window."""

    value: float
    frames_used: int
    frames_rejected: int = 0
    diagnostics: dict = field(default_factory=dict)


class Processor:
    """Base class: override ``msg_type``, ``process`` and maybe
    ``device_stamp``."""

    msg_type = 'hri_sync/Sample'

    def __init__(self, **params):
        if params:
            raise ValueError('%s takes no parameters, got %s'
                             % (type(self).__name__,
                                ', '.join(sorted(params))))

    def device_stamp(self, msg):
        """The sample's own device time in s, or None to stamp at arrival."""
        return None

    def process(self, frames, start, end):
        """Return a ProcessResult for ``frames`` in [start, end)."""
        raise NotImplementedError


class CountMean(Processor):
    """Count and mean of a numeric stream (``hri_sync/Sample.value``).

    Non-finite values are rejected and counted.
    """

    def process(self, frames, start, end):
        values = [f.msg.value for f in frames]
        good = [v for v in values if math.isfinite(v)]
        mean = sum(good) / len(good) if good else math.nan
        return ProcessResult(value=mean, frames_used=len(good),
                             frames_rejected=len(values) - len(good),
                             diagnostics={'count': len(good)})


class DeviceStampedCountMean(CountMean):
    """CountMean of a sensor whose ``header.stamp`` is its own clock (as
    ``hri_sync/Sample`` documents it), for ``stamp_source: device``."""

    def device_stamp(self, msg):
        return msg.header.stamp.to_sec()


def load_processor(path, params=None):
    """Instantiate the Processor subclass at class path ``path``.

    Raises ValueError naming the path when it cannot be imported or is not
    a Processor.
    """
    module_name, _, class_name = path.rpartition('.')
    if not module_name:
        raise ValueError('~processor must be a class path like '
                         "'hri_sync.timing.processors.CountMean', got %r"
                         % path)
    try:
        cls = getattr(importlib.import_module(module_name), class_name)
    except (ImportError, AttributeError) as e:
        raise ValueError('~processor %r cannot be loaded: %s' % (path, e))
    if not (isinstance(cls, type) and issubclass(cls, Processor)):
        raise ValueError('~processor %r is not a hri_sync Processor' % path)
    try:
        return cls(**(params or {}))
    except TypeError as e:
        raise ValueError('~processor_params do not fit %s: %s' % (path, e))
