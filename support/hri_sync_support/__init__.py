"""What the benches and test checkers share; not installed with hri_sync.

``harness`` runs the stack for a bench or a checker (processes, faketime
clients, the true-clock reference, free ports, polled waits, bounded
runs), ``skew_bench`` is the start-skew benches' stack and recording node,
``skew_figures`` their figures.  On the path of bench/ and scripts/ by
``sys.path``, of the rostest checkers by the ``PYTHONPATH`` their launch
files set, of pytest by test/unit/conftest.py.
"""
