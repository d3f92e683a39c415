"""Stock processors for standard ROS sensor messages (docs/sensors.md).

No ROS: each module turns one message type into a physical result of a
capture window, validates each message at the boundary (``check`` raises
``hri_sync.wire.validate.Rejected`` with a reason the DPM counts) and
reads its messages by attribute, so tests feed plain objects.

- ``image.ImageMotion``: sensor_msgs/Image, motion energy;
- ``imu.ImuActivity``: sensor_msgs/Imu, activity;
- ``joint_state.JointSpeed``: sensor_msgs/JointState, mean squared joint
  speed;
- ``audio.AudioLevel``: hri_sync/AudioChunk, level and voice activity;
- ``generic.HeaderCount``: any message with a std_msgs/Header, counted.

Imports the layers below it only (``wire``, ``data_process``, ...).
"""
