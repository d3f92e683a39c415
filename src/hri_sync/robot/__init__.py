"""DJ Rob: the robot's side of a round, plain Python with no ROS.

Contract: imports nothing from ``hri_sync`` above ``hri_sync.dance_off``, no
rospy, and reads no clock (callers pass times or clocks).  Its modules,
lowest first (each imports only those before it): ``geometry`` (angles,
quaternion <-> yaw, the odometry transform), ``kobuki`` (the base: its
velocity command, limits, LED and sound values, and the base model),
``choreography`` (the dance and the winner gesture as twists over time),
``music`` (the track's beats; independent of the others), ``dj_rob`` (the
job scheduler: rounds and decisions become motions on the global clock,
with preemption and late joins on the beat) and ``report`` (what the
monitor prints about a round).
"""
