"""REP 155 bodies as ROS messages: a hri_sync/Skeleton's tf tree and the
tracked ids (rep155_bridge, fuse_bag)."""
from tf2_msgs.msg import TFMessage

from hri_sync.msg import IdsList
from hri_sync.people.rep155 import body_transforms
from hri_sync.ros.stamps import header
from hri_sync.ros.transforms import transform


def body_tf(msg, body_id):
    """The tf tree of body ``body_id`` from Skeleton ``msg`` (under its
    header.frame_id, stamped with its header stamp), or None when its
    hips and neck are not tracked."""
    links = body_transforms(body_id, [(p.x, p.y, p.z)
                                      for p in msg.positions])
    if not links:
        return None
    return TFMessage([transform(msg.header.stamp,
                                parent or msg.header.frame_id, child, t, q)
                      for parent, child, t, q in links])


def ids_list(ids, stamp):
    """/humans/bodies/tracked's message: ``ids``, stamped ``stamp`` (a
    rospy.Time; None: zero)."""
    msg = IdsList(ids=ids)
    msg.header = header(None)
    if stamp is not None:
        msg.header.stamp = stamp
    return msg
