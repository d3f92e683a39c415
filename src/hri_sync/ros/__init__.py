"""The ROS shell: what the executables in nodes/ share.

Contract: with each module's ``ros_*.py`` shells, the only code that
imports rospy.  ``params`` reads ``~params`` with checks, ``node``
starts a node and ends it (a config error, a master restart, its parent
gone), ``stamps`` turns seconds into validated ROS times, ``timers``
holds the polled waits that work under libfaketime, ``round_log``
records what each round put on the wire,
``master_watch`` (started by ``node.run_node`` for every node) ends a
node for respawn when the ROS master restarted, ``diagnostics``
publishes the core's health checks on /diagnostics, ``names`` resolves
the protocol and client topics in the system namespace (a client's node
lives in NS/<client_id>/), and ``unique`` (run by ``node.run_node``)
refuses to start a node beside a live node of its name.  Logic
lives in the core; these modules wire it to topics.
"""
