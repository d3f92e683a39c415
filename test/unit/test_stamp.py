"""hri_sync.ros.stamps.stamp: never a time it did not validate."""
import math

import pytest
import rospy

from hri_sync.ros.stamps import StampError, header, stamp


def test_valid_time():
    t = stamp(1_700_000_000.25)
    assert isinstance(t, rospy.Time)
    assert (t.secs, t.nsecs) == (1_700_000_000, 250_000_000)
    assert stamp(2.0 ** 32 - 0.5).secs == 2 ** 32 - 1


def test_none_is_the_explicit_no_time():
    assert stamp(None) == rospy.Time()


@pytest.mark.parametrize('t,reason', [
    (math.nan, 'time_not_finite'), (math.inf, 'time_not_finite'),
    (0.0, 'time_not_positive'), (-3.0, 'time_not_positive'),
    (2.0 ** 32, 'time_unrepresentable'),
    (4294967290.0 + 60.3, 'time_unrepresentable')])
def test_refuses_what_rospy_cannot_send(t, reason):
    with pytest.raises(StampError) as e:
        stamp(t)
    assert e.value.reason == reason


def test_header_stamp_goes_through_stamp():
    h = header(1_700_000_000.5, 'left_sensor')
    assert (h.stamp.secs, h.stamp.nsecs, h.frame_id) == \
        (1_700_000_000, 500_000_000, 'left_sensor')
    assert header(None).stamp == rospy.Time() and header(None).frame_id == ''
    with pytest.raises(StampError) as e:
        header(math.nan)
    assert e.value.reason == 'time_not_finite'
