"""Float seconds to rospy times and headers, validated (what fits in a
ROS time: hri_sync.wire.times.fits_ros_time)."""
import rospy
from std_msgs.msg import Header

from hri_sync.wire.validate import Rejected, time_value


class StampError(ValueError):
    """A time that must not be published: not finite, not positive or
    beyond the last ROS time (rospy cannot serialise it, and a publisher
    that tries corrupts its link for good).  ``reason`` is the key of
    hri_sync.wire.validate."""

    def __init__(self, reason, message):
        super().__init__(message)
        self.reason = reason


def stamp(t):
    """A float of seconds as rospy.Time, validated first.

    None is the explicit "no time" (a zero time, for fields whose contract
    says 0 means unknown); a time that is not finite, not positive or not
    a ROS time (``fits_ros_time``) raises StampError instead of going out.
    """
    if t is None:
        return rospy.Time()
    try:
        time_value(t, 'stamp')
    except Rejected as e:
        raise StampError(e.reason, str(e))
    return rospy.Time.from_sec(t)


def header(t, frame_id=''):
    """A std_msgs/Header whose stamp is ``stamp(t)`` (validated; None: a
    zero time); rospy fills in its seq."""
    return Header(stamp=stamp(t), frame_id=frame_id)


def secs(t):
    """A rospy.Time or Duration as float seconds."""
    return t.to_sec()
