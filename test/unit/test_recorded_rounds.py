"""verify on the recorded dance-off rounds shipped in test/bags/.

rounds_dancers.bag (3 rounds, two salsa dancers) and rounds_pilot.bag (2
rounds, small movements vs still) were recorded by dance_off.launch
bag:=... from the skeleton bags of scripts/make_test_bags.py, with an
earlier version of hri_sync's messages (so they are read with their own
definitions: allow_old).
"""
import copy
import os

import pytest

from hri_sync.dance_off import verify

pytest.importorskip('rosbags', reason='rosbags is installed by make venv')

from hri_sync.tools.bag import read_bag  # noqa: E402
from hri_sync.tools.session import build_session  # noqa: E402

BAGS = os.path.join(os.path.dirname(__file__), '..', 'bags')


def recording(name):
    """(decisions, results, captured, config, aborted) of a shipped bag."""
    s = build_session(read_bag(os.path.join(BAGS, name + '.bag'),
                               allow_old=True))
    decisions = [r.decision.msg for r in s.rounds.values() if r.decision]
    results = [r.msg for rnd in s.rounds.values()
               for r in rnd.results.values()]
    aborted = {n: r.aborted_reason for n, r in s.rounds.items()
               if r.aborted_reason is not None}
    return decisions, results, s.captured, s.config, aborted


@pytest.mark.parametrize('name, rounds, winner', [
    ('rounds_dancers', 3, 2), ('rounds_pilot', 2, 1)])
def test_every_recorded_round_agrees(name, rounds, winner):
    decisions, results, captured, config, aborted = recording(name)
    assert config == {'min_expressiveness': 1.0, 'tie_margin': 0.0,
                      'on_missing': 'partial'}
    checks = verify.check_recording(decisions, results, captured, config,
                                    aborted)
    assert len(checks) == rounds
    assert all(c.ok for c in checks), verify.format_table(checks)
    assert {c.winner for c in checks} == {winner}
    assert all(len(c.clients) == 2 for c in checks)


def test_tampered_recording_disagrees():
    decisions, results, captured, config, aborted = recording(
        'rounds_pilot')
    swapped = copy.deepcopy(decisions)
    swapped[0].winner = 2
    checks = verify.check_recording(swapped, results, captured, config)
    assert not checks[0].ok and checks[1].ok
    results[0].value *= 1.001
    checks = verify.check_recording(decisions, results, captured, config)
    assert sum(not c.ok for c in checks) == 1
