"""The 15 OpenNI/NiTE joints, in the fixed order of ``hri_sync/Skeleton``.

This list is the one place joint names live; ``Skeleton.msg`` carries the
matching index constants (a unit test checks they agree).
"""
from hri_sync.wire.vocabulary import NUM_JOINTS  # noqa: F401 (one count)

JOINTS = (
    'head', 'neck', 'torso',
    'left_shoulder', 'right_shoulder',
    'left_elbow', 'right_elbow',
    'left_hand', 'right_hand',
    'left_hip', 'right_hip',
    'left_knee', 'right_knee',
    'left_foot', 'right_foot',
)
INDEX = {name: i for i, name in enumerate(JOINTS)}
