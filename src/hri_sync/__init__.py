"""hri_sync: time-synchronized sensing and robot action for HRI.

Layers, lowest first (a layer imports only those before it):

- ``hri_sync.wire``: what travels between the modules (words, stamps,
  the protocol's records, input validation, health values);
- ``hri_sync.clock``: the clock model, NTP, keeping a host's clock;
- the paper's four modules (Figure 3), side by side:
  ``hri_sync.control`` (CM), ``hri_sync.decision`` (DM),
  ``hri_sync.client_process`` (CPM), ``hri_sync.data_process`` (DPM);
- ``hri_sync.people`` and ``hri_sync.sensors``: other trackers' formats
  and the stock processors of standard sensor messages;
- ``hri_sync.dance_off``: motion, joints, expressiveness, verification;
- ``hri_sync.robot``: DJ Rob's choreography, the Kobuki base model, music
  and the action scheduler;
- ``hri_sync.tools``: offline tools (round summaries, bag reports);
- ``hri_sync.ros``: the ROS plumbing the executables in ``nodes/`` share.

Only ``hri_sync.ros`` and the modules named ``ros_*.py`` (each module's
ROS shell, beside its core) import rospy; they stand above every layer.

docs/architecture.md maps one round onto these modules and topics.
"""
