"""Publishers that never corrupt their links.

rospy serialises a message into a buffer it shares with the next one; a
field it cannot serialise (a time past 2**32 s, a count past its uint32,
a fixed array of the wrong length) raises halfway and leaves the partial
bytes there, so the next message goes out behind them and every
subscriber drops the connection for good.  ``Publisher``
serialises each message into a scratch buffer first and raises
``Unsendable`` before rospy's buffer is touched: the message is lost, the
link is not.
"""
import contextlib
import io

import rospy
from rospy.msg import args_kwds_to_message


class Unsendable(ValueError):
    """A message rospy cannot serialise; it was not published."""


def check_sendable(msg):
    """Raise Unsendable if rospy cannot serialise ``msg``."""
    try:
        msg.serialize(io.BytesIO())
    except Exception as e:     # struct.error, SerializationError, TypeError
        raise Unsendable('%s not published: %s'
                         % (getattr(msg, '_type', type(msg).__name__), e))


@contextlib.contextmanager
def closed_at_shutdown():
    """Ends its block quietly when a publish in it meets a topic rospy
    closed at shutdown (it closes them before ``rospy.is_shutdown()``
    turns true, so a thread's last publish raises); any other time the
    ROSException propagates."""
    try:
        yield
    except rospy.ROSException:
        if not rospy.core.is_shutdown_requested():
            raise


class Publisher(rospy.Publisher):
    """rospy.Publisher whose ``publish`` refuses (Unsendable) a message
    it cannot serialise instead of corrupting the link, and does nothing
    once the node shuts down (rospy closes its topics before
    ``rospy.is_shutdown()`` turns true, so a thread's last publish would
    raise)."""

    def publish(self, *args, **kwds):
        msg = args_kwds_to_message(self.data_class, args, kwds)
        check_sendable(msg)
        with closed_at_shutdown():
            super().publish(msg)
