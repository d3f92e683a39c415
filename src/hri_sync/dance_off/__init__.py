"""The dance-off: motion, joints, expressiveness and verification.

Contract: builds on the layers below it only (``wire``, ``decision``,
...).  ``bvh`` and ``motion`` load
CMU motion capture into 15-joint ``Motion`` clips, ``skeleton_source``
replays them as a sensor would (noise, drops, NaN joints),
``expressiveness`` is the DPM processor that scores a window, and
``verify`` recomputes a recorded session's decisions from its bag.
"""
