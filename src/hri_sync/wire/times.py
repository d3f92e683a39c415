"""The four clocks as types (docs/architecture.md, "the four clocks").

No ROS, no runtime cost: each is a ``typing.NewType`` over float, so mypy
(``make check``) refuses a local time where a global one is due, while at
run time they are plain floats.  A value changes clock only through a
mapping: ``ClockModel.to_global``/``to_local`` (local <-> global), a
``TimeMapping`` (a sample's source time -> global), the truth helpers
(true time, in tests and benches).
"""
from typing import NewType

TrueTime = NewType('TrueTime', float)       # the raw monotonic clock: truth
LocalTime = NewType('LocalTime', float)     # this process's system clock
GlobalTime = NewType('GlobalTime', float)   # the time server's clock
DeviceTime = NewType('DeviceTime', float)   # a sensor's own clock
Seconds = float                             # a duration, on any clock
