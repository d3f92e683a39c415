"""The decision module (DM): who was the most expressive (no ROS outside
the ``ros_*`` shells).

``rule``: the decision rule over the clients' results; ``health``: its
decisions on /diagnostics.
"""
