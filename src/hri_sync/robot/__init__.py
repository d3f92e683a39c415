"""DJ Rob: the robot's side of a round, plain Python with no ROS.

Contract: builds on ``hri_sync.timing`` only.  ``kobuki`` models the base
(its limits, velocity commands and odometry), ``choreography`` plans the
dance and the winner gesture as twists over time, ``music`` knows the
track's beats, and the action scheduler turns rounds and decisions into
jobs that start on the global clock.
"""
