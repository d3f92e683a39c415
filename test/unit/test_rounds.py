"""hri_sync.wire.rounds: one rule for a second order of a round, which the
DM's collector and the DPM follow alike."""
import math

import pytest

from hri_sync.clock.model import ClockModel
from hri_sync.data_process.dpm import DataProcess
from hri_sync.data_process.processors import CountMean
from hri_sync.decision.rule import RoundCollector
from hri_sync.wire.rounds import CONFLICTING, DUPLICATE, repeated_order


@pytest.mark.parametrize('window, known, is_open, want', [
    ((1.0, 2.0), [], False, ('', True)),
    ((1.0, 2.0), [(1.0, 2.0)], True, (DUPLICATE, False)),
    ((1.0, 2.0), [(0.0, 1.0), (1.0, 2.0)], False, (DUPLICATE, False)),
    ((1.0, 3.0), [(1.0, 2.0)], True, (CONFLICTING, False)),
    ((1.0, 3.0), [(1.0, 2.0)], False, (CONFLICTING, True)),
    ((3.0,), [(math.nan,)], False, (DUPLICATE, False)),
])
def test_repeated_order(window, known, is_open, want):
    assert repeated_order(window, known, is_open) == want


# (window end, close the round after this order)
ORDERS = [(500.0, False), (500.0, True), (1000.0, False), (2000.0, False),
          (500.0, True), (500.0, False)]


def test_the_dm_and_the_dpm_take_the_same_orders():
    """A forged order of round 3, the same again, closed; the rightful
    one, another while it is open, the forged one again, closed; the
    forged one once more: both modules take the first and the rightful
    one and count the rest alike (a window a round had is never taken
    again)."""
    dm = RoundCollector(['left'], result_timeout=0.5)
    dpm = DataProcess(CountMean)
    dpm.set_clock(ClockModel(0.0, 0.0, 0.0, 1e-4))
    taken = []
    for end, close in ORDERS:
        dm_took = dm.open(3, end)
        window = dpm.windows.get(3)
        dpm.open(3, end - 1.0, end)
        taken.append((dm_took, dpm.windows.get(3) is not window))
        if close:
            dm.due(end + 1.0)
            dpm.poll(end + 1.0)
    assert taken == [(True, True), (False, False), (True, True),
                     (False, False), (False, False), (False, False)]
    assert dm.ignored == {'duplicate_round': 3, 'conflicting_round': 2}
    assert {k: n for k, n in dpm.counts.items() if 'command' in k} == {
        'duplicate_command': 3, 'conflicting_command': 2}


def test_a_round_aborted_before_its_order_ignores_it():
    dm = RoundCollector(['left'], result_timeout=0.5)
    dm.abort(4, 'no ACK from left')
    assert not dm.open(4, 100.0)
    assert dm.ignored == {'duplicate_round': 1}
