"""pytest setup for the unit and system tests."""
import os
import signal
import sys

# A suite started in the background by a non-interactive shell (`make test
# &`) inherits SIGINT and SIGQUIT ignored, and so would every process a
# test starts: tests that stop a child with SIGINT (or a lifeline that
# sends it) would then fail for a reason outside the code under test.
if signal.getsignal(signal.SIGINT) == signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)
if signal.getsignal(signal.SIGQUIT) == signal.SIG_IGN:
    signal.signal(signal.SIGQUIT, signal.SIG_DFL)

# The bench and test support package (support/, not installed).
sys.path.insert(0, os.path.join(os.path.dirname(os.path.abspath(__file__)),
                                '..', 'support'))
