"""Recorded skeleton streams read with rosbag (the replay sensor's input).

The ordering of a recorded stream for replay is the core's
(``hri_sync.dance_off.skeleton_source.recorded_frames``); this reads it.
"""
from hri_sync.dance_off.skeleton_source import recorded_frames
from hri_sync.ros.params import ParamError


def read_skeletons(path, topic):
    """The hri_sync/Skeleton frames on ``topic`` of bag ``path`` (the one
    Skeleton topic when ``topic`` is empty; a relative or absolute name),
    in replay order: (frames, their times from 0, the topic).  ParamError
    naming the bag when it cannot be read or holds < 2 frames."""
    import rosbag
    try:
        with rosbag.Bag(path) as bag:
            topics = bag.get_type_and_topic_info().topics
            if not topic:
                found = [t for t, info in topics.items()
                         if info.msg_type == 'hri_sync/Skeleton']
                if len(found) != 1:
                    raise ParamError('~bag %s has %d hri_sync/Skeleton topics '
                                     '(%s): set ~bag_topic' % (
                                         path, len(found), ', '.join(found)))
                topic = found[0]
            # recorded by a relative name ('left/skeleton') or not
            topic = next((t for t in topics
                          if t.lstrip('/') == topic.lstrip('/')), topic)
            msgs = [m for _, m, _ in bag.read_messages(topics=[topic])]
    except (OSError, rosbag.ROSBagException) as e:
        raise ParamError('~bag %s cannot be read: %s' % (path, e))
    if len(msgs) < 2:
        raise ParamError('~bag %s: %d Skeleton frames on %s, need >= 2'
                         % (path, len(msgs), topic))
    frames, rel = recorded_frames(msgs, [m.device_stamp.to_sec()
                                         for m in msgs])
    return frames, rel, topic
