"""Offline tools over recorded rounds: summaries, reports; the process tree.

Contract: reads what rounds put on the wire (live ``RoundLog`` records or
bags) and computes figures from it with the core modules,
``hri_sync.dance_off`` and ``hri_sync.robot``; imports no rospy.
``procs`` walks, signals and reaps a process tree (``skewed_client``, the
benches and the checkers).  The benches' and checkers' harness is not
here: it is ``support/hri_sync_support`` (not installed).
"""
