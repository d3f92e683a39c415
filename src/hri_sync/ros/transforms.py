"""A tf2 transform message from plain values."""
from geometry_msgs.msg import TransformStamped


def transform(stamp, parent, child, xyz, q):
    """A geometry_msgs/TransformStamped of frame ``child`` in ``parent``
    at ``stamp`` (a rospy.Time): translation ``xyz``, rotation ``q``
    (x, y, z, w)."""
    tr = TransformStamped()
    tr.header.stamp, tr.header.frame_id = stamp, parent
    tr.child_frame_id = child
    (tr.transform.translation.x, tr.transform.translation.y,
     tr.transform.translation.z) = xyz
    (tr.transform.rotation.x, tr.transform.rotation.y,
     tr.transform.rotation.z, tr.transform.rotation.w) = q
    return tr
