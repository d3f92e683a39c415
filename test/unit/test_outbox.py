"""hri_sync.ros.outbox: a message rospy cannot serialise is refused
before it reaches the shared buffer (no master needed)."""
import io
import math

import genpy
import pytest
from geometry_msgs.msg import Twist
from std_msgs.msg import Header

from hri_sync.ros import outbox
from hri_sync.ros.outbox import Unsendable, check_sendable


def late_header():
    h = Header()
    h.stamp.secs, h.stamp.nsecs = 2 ** 32 - 1, 0
    h.stamp.secs += 5           # as a time past 2**32 s arrives from a fuzzer
    return h


def test_sendable_messages_pass():
    check_sendable(Twist())
    t = Twist()
    t.linear.x = math.nan       # float64 carries NaN: sendable
    check_sendable(t)


@pytest.mark.parametrize('make', [
    late_header,
    lambda: Header(seq=2 ** 32),
    lambda: Header(frame_id=3)])
def test_unsendable_messages_are_refused(make):
    with pytest.raises(Unsendable, match='std_msgs/Header not published'):
        check_sendable(make())


def test_rospy_would_corrupt_its_buffer():
    # What Unsendable prevents: the failed serialisation leaves partial
    # bytes in the buffer that the next message is appended to.
    b = io.BytesIO()
    with pytest.raises(genpy.SerializationError):
        Header(seq=7, frame_id=3).serialize(b)
    assert b.tell() == 12       # seq and stamp written, then it failed


def test_publisher_refuses_before_publishing(monkeypatch):
    sent = []
    monkeypatch.setattr(outbox.rospy.Publisher, 'publish',
                        lambda self, msg: sent.append(msg))
    pub = outbox.Publisher.__new__(outbox.Publisher)
    pub.data_class = Header
    pub.publish(Header(seq=1))
    with pytest.raises(Unsendable):
        pub.publish(late_header())
    with pytest.raises(Unsendable):
        pub.publish(seq=2 ** 33)
    assert [m.seq for m in sent] == [1]


@pytest.mark.parametrize('shutting_down', [False, True])
def test_a_closed_topic_raises_unless_the_node_shuts_down(monkeypatch,
                                                           shutting_down):
    # rospy closes its topics in its shutdown hooks, before is_shutdown()
    # turns true: a heartbeat thread's last publish meets a closed topic.
    def closed(self, msg):
        raise outbox.rospy.ROSException('publish() to a closed topic')
    monkeypatch.setattr(outbox.rospy.Publisher, 'publish', closed)
    monkeypatch.setattr(outbox.rospy.core, 'is_shutdown_requested',
                        lambda: shutting_down)
    pub = outbox.Publisher.__new__(outbox.Publisher)
    pub.data_class = Header
    if shutting_down:
        pub.publish(Header(seq=1))
    else:
        with pytest.raises(outbox.rospy.ROSException, match='closed topic'):
            pub.publish(Header(seq=1))


@pytest.mark.parametrize('shutting_down', [False, True])
def test_a_block_meeting_a_closed_topic_ends_quietly_only_at_shutdown(
        monkeypatch, shutting_down):
    # a timer's or thread's loop (kobuki_sim, the republisher, the
    # diagnostics) publishing as rospy closes its topics
    monkeypatch.setattr(outbox.rospy.core, 'is_shutdown_requested',
                        lambda: shutting_down)
    with pytest.raises(ZeroDivisionError):
        with outbox.closed_at_shutdown():
            1 / 0               # any other error goes through
    if shutting_down:
        with outbox.closed_at_shutdown():
            raise outbox.rospy.ROSException('publish() to a closed topic')
    else:
        with pytest.raises(outbox.rospy.ROSException):
            with outbox.closed_at_shutdown():
                raise outbox.rospy.ROSException('publish() to a closed topic')
