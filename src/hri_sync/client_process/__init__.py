"""The client process module (CPM): a client's answers to sync_time and
its capture orders (no ROS outside the ``ros_*`` shells).

``schedule``: ACK or NACK, and a capture order turned into a local start;
``liveness``: is the client's DPM alive and its sensor delivering;
``health``: its rounds on /diagnostics; ``ros_cpm``: the CPM on ROS.
"""
