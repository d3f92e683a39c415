"""hri_sync: time-synchronized sensing and robot action for HRI.

The modules here are the functional core (no rospy import) except
``hri_sync.rosutil``, the thin glue the nodes in ``nodes/`` share.
"""
