"""Offline tools over recorded rounds: summaries and reports.

Contract: reads what rounds put on the wire (live ``RoundLog`` records or
bags) and computes figures from it with ``hri_sync.timing``,
``hri_sync.dance_off`` and ``hri_sync.robot``; imports no rospy.
"""
