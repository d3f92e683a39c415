"""The timing model, plain Python with no ROS.

Contract: every function and state machine here takes its clock as a
value or a callable (never ``time.time()`` inside), works on float seconds
of one of four clocks (true, local, global, device; see docs/glossary in
docs/architecture.md) and returns results or raises ``ValueError``
subclasses; nothing here publishes or sleeps.  It holds the clock model
and NTP estimation (``clock``, ``ntp``), keeping a clock against the time
server with its holdover (``clock_sync``), the CM/CPM protocol state
machines (``protocol``; the CM's session of rounds, ``control``), the
DPM's capture window and time mapping (``capture``), processors and
decisions (``processors``, ``decision``), skew measurement against the
true clock (``skew``, ``truth``), and the nodes' health for /diagnostics
from plain values (``health``).
"""
