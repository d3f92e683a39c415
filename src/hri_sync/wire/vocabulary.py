"""The protocol's words and defaults, defined once.

No ROS: the core may not import the generated messages, so the message
constants are mirrored here, and ``test/unit/test_vocabulary.py`` checks
each against its ``msg/*.msg`` definition (and that no module spells one
out as a bare string).  The defaults the nodes, the core and the launch
files share are here too; the same test checks the launch files' values.
"""

NUM_JOINTS = 15             # Skeleton.NUM_JOINTS


class ResultStatus:
    """``ClientResult.status``."""

    OK = 'ok'
    PARTIAL = 'partial'
    NO_DATA = 'no_data'
    LATE = 'late'
    ERROR = 'error'
    ALL = (OK, PARTIAL, NO_DATA, LATE, ERROR)
    USABLE = (OK, PARTIAL)          # statuses whose value is a score


class NoiseSource:
    """``ClientResult.noise_source``: where a noise floor's quiet level
    came from (its ``NOISE_`` constants); '' when there is no floor."""

    NOISE_CALIBRATION = 'calibration'
    NOISE_UNCALIBRATED = 'uncalibrated'
    NOISE_ESTIMATE = 'estimate'
    ALL = (NOISE_CALIBRATION, NOISE_UNCALIBRATED, NOISE_ESTIMATE)
    # what the decision module's noise rule trusts ('' : a recording made
    # before the field, decided as it was)
    TRUSTED = (NOISE_CALIBRATION, NOISE_ESTIMATE, '')


class Outcome:
    """``Decision.outcome``."""

    WINNER = 'winner'
    NO_WINNER = 'no_winner'
    TIE = 'tie'
    ABORTED = 'aborted'
    ALL = (WINNER, NO_WINNER, TIE, ABORTED)


class RoundState:
    """``RoundStatus.state``."""

    SYNCING = 'syncing'
    CAPTURING = 'capturing'
    ABORTED = 'aborted'
    ALL = (SYNCING, CAPTURING, ABORTED)


class Action:
    """``ActionStart``: its built-in actions, kinds, events, statuses."""

    DANCE = 'dance'
    MUSIC = 'music'
    PUBLISH = 'publish'
    SERVICE = 'service'
    ACTIONLIB = 'actionlib'
    COMMAND = 'command'
    WINDOW_START = 'window_start'
    WINDOW_END = 'window_end'
    DECISION = 'decision'
    OK = 'ok'
    LATE = 'late'
    FAILED = 'failed'
    KINDS = (PUBLISH, SERVICE, ACTIONLIB, COMMAND)
    EVENTS = (WINDOW_START, WINDOW_END, DECISION)
    STATUSES = (OK, LATE, FAILED)
    ALL = (DANCE, MUSIC) + KINDS + EVENTS + STATUSES


class ActionEnd:
    """``ActionEnd.status``: how an action that began ended."""

    OK = 'ok'
    FAILED = 'failed'
    TIMEOUT = 'timeout'
    STATUSES = (OK, FAILED, TIMEOUT)
    ALL = STATUSES


# The calibration window's round number on the calibration/ topics (the
# rounds count from 1): not a round, nobody moves, no winner.
CALIBRATION_ROUND = 0
CALIBRATION_NS = 'calibration'     # its topics: calibration/capture_data, ...

# The DM's ~on_missing: decide over the results present, or abort.
ON_MISSING = ('partial', 'abort')

# Defaults (launch files pass the same values; the test checks them).
DRIFT_BOUND = 15e-6         # s/s, the clock error growth without a sync
MIN_COVERAGE = 0.9          # share of a window below which a result is partial
MAX_UNCERTAINTY = 0.005     # s, a CPM NACKs a round with a less certain clock
COMPLETION_MARGIN = 0.03    # s a window waits for a due sample past its end
