"""The four clocks as types (docs/architecture.md, "the four clocks").

No ROS, no runtime cost: each is a ``typing.NewType`` over float, so mypy
(``make check``) refuses a local time where a global one is due, while at
run time they are plain floats.  A value changes clock only through a
mapping: ``ClockModel.to_global``/``to_local`` (local <-> global), a
``TimeMapping`` (a sample's source time -> global), the truth helpers
(true time, in tests and benches).
"""
import math
from typing import NewType

TrueTime = NewType('TrueTime', float)       # the raw monotonic clock: truth
LocalTime = NewType('LocalTime', float)     # this process's system clock
GlobalTime = NewType('GlobalTime', float)   # the time server's clock
DeviceTime = NewType('DeviceTime', float)   # a sensor's own clock
Seconds = float                             # a duration, on any clock

# s: the first time a ROS time (uint32 seconds) cannot carry; its C++ twin
# is kTimeLimit in include/hri_sync/clock_map.h.
TIME_LIMIT = 2.0 ** 32


def fits_ros_time(t: float, zero: bool = False) -> bool:
    """True for a finite ``t`` in (0, TIME_LIMIT) s, what a ROS time can
    carry (``zero``: [0, TIME_LIMIT), 0 as a valid time too)."""
    return math.isfinite(t) and (t >= 0 if zero else t > 0) \
        and t < TIME_LIMIT
