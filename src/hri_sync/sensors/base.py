"""What the stock sensor processors share: header stamps and checks."""
import math

from hri_sync.data_process.processors import Processor
from hri_sync.wire.validate import Rejected


def seconds(t):
    """A ROS time (``to_sec`` or ``secs``/``nsecs``) or a number, in s."""
    if hasattr(t, 'to_sec'):
        return t.to_sec()
    if hasattr(t, 'secs'):
        return t.secs + 1e-9 * t.nsecs
    return float(t)


def finite(values, what):
    """Raise Rejected('not_finite') unless every value is a finite
    number."""
    for i, v in enumerate(values):
        try:
            ok = math.isfinite(v)
        except TypeError:
            raise Rejected('not_a_number', '%s[%d]=%r is not a number'
                           % (what, i, v), what)
        if not ok:
            raise Rejected('not_finite', '%s[%d] is %r' % (what, i, v), what)


def xyz(v, what):
    """The (x, y, z) of a geometry_msgs/Vector3, each finite."""
    try:
        out = (v.x, v.y, v.z)
    except AttributeError:
        raise Rejected('malformed', '%s is not a vector' % what, what)
    finite(out, what)
    return out


class HeaderStamped(Processor):
    """A processor of a message with a std_msgs/Header whose
    ``header.stamp`` is the sensor's capture time (on the sensor's or its
    host's clock, as drivers stamp): its device stamp, mapped to global
    time by the DPM's device clock map (``stamp_source: auto``); use
    ``stamp_source: arrival`` for a driver that does not stamp."""

    def device_stamp(self, msg):
        return seconds(msg.header.stamp)
