"""The control module (CM): numbered rounds, one at a time (no ROS
outside the ``ros_*`` shells).

``session``: the CM's session of rounds; ``round``: one round (sync_time
out, ACKs in, capture_data or abort); ``calibration``: the window with
nobody moving before round 1; ``health``: its rounds on /diagnostics.
"""
