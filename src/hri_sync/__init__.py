"""hri_sync: time-synchronized sensing and robot action for HRI.

Layers, lowest first (a layer imports only those before it):

- ``hri_sync.timing``: the timing model (clocks, NTP, protocol state
  machines, capture windows, time mapping, decisions, input validation);
- ``hri_sync.dance_off``: motion, joints, expressiveness, verification;
- ``hri_sync.robot``: DJ Rob's choreography, the Kobuki base model, music
  and the action scheduler;
- ``hri_sync.tools``: offline tools (round summaries, bag reports);
- ``hri_sync.ros``: the ROS shell the executables in ``nodes/`` share (the
  only subpackage that imports rospy).

docs/architecture.md maps one round onto these modules and topics.
"""
