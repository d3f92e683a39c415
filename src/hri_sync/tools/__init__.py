"""Offline tools over recorded rounds: summaries, reports, the test harness.

Contract: reads what rounds put on the wire (live ``RoundLog`` records or
bags) and computes figures from it with ``hri_sync.timing``,
``hri_sync.dance_off`` and ``hri_sync.robot``; imports no rospy.
``harness`` is what benches and test checkers share to run the stack
(processes, faketime clients, the true-clock reference), ``skew_figures``
the start-skew benches' figures.
"""
