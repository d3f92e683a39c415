"""Message classes by type name, with errors that list what exists."""
import os

import rospkg
import roslib.message

from hri_sync.wire.config import unknown


def message_class(type_name):
    """The class of message type ``type_name`` ('package/Type').

    Raises ValueError naming the valid packages (those with messages) or
    the package's types, with the nearest match.  A package that is not
    or a type that is not there is found out here, before roslib asks
    rospack (whose answer is about rosdep).
    """
    pkg, _, name = str(type_name).partition('/')
    packs = rospkg.RosPack()
    try:
        path = packs.get_path(pkg)
    except rospkg.ResourceNotFound:
        having = [p for p in packs.list()
                  if os.path.isdir(os.path.join(packs.get_path(p), 'msg'))]
        raise ValueError(unknown('message package', pkg, having))
    folder = os.path.join(path, 'msg')
    types = [f[:-len('.msg')] for f in (
        os.listdir(folder) if os.path.isdir(folder) else ())
        if f.endswith('.msg')]
    cls = roslib.message.get_message_class(type_name) \
        if name in types else None
    if cls is None:
        raise ValueError(unknown('message type of %s' % pkg, name, types))
    return cls
