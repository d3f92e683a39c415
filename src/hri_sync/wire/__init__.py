"""What travels between the modules, in plain Python (no ROS).

``vocabulary``: the protocol's words and defaults; ``times``: the four
clocks as types (the stamps); ``protocol``: the records both ends of a
round exchange (Ack, Capture, Abort, the start-after policy);
``rounds``: the one rule for a second order of a round; ``validate``:
one check per incoming message type; ``health``: a DiagnosticStatus as a
plain value and the counters the modules report with.  Imports nothing
else of ``hri_sync``.
"""
