"""What the benches and test checkers share; not installed with hri_sync.

``harness`` runs the stack for a bench or a checker (processes, faketime
clients, the true-clock reference, free ports, polled waits, bounded
runs), ``skew_bench`` is the start-skew benches' stack and recording node,
``skew_figures`` their figures, ``forkserver`` the rostests' fork server
(its startup hook: ``support/forkserver/sitecustomize.py``; what the two
agree on: ``fork_protocol``).  On the path
of bench/ and scripts/ by ``sys.path``, of the rostests by the
``PYTHONPATH`` scripts/run_rostests.py sets, of pytest by
test/unit/conftest.py.
"""
