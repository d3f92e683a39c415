"""hri_sync.dance_off.verify: recomputing rounds from captured frames."""

import math
from types import SimpleNamespace as NS

import numpy as np
import pytest

from hri_sync.dance_off.verify import check_recording, format_table

CONFIG = {'min_expressiveness': 1.0, 'tie_margin': 0.0,
          'on_missing': 'partial'}


def t(sec):
    whole = int(math.floor(sec))
    return NS(sec=whole, nanosec=int(round((sec - whole) * 1e9)))


def skeleton(stamp, x):
    pts = [NS(x=x, y=0.0, z=2.5) for _ in range(15)]
    return NS(header=NS(stamp=t(stamp)), positions=pts,
              confidence=np.ones(15, dtype=np.float32))


def stream(speed, start=100.0, dur=2.0, rate=20.0):
    """Frames of 15 joints moving along x at ``speed`` m/s."""
    stamps = start + 0.01 + np.arange(int(dur * rate)) / rate
    return [(s, skeleton(s, speed * (s - start))) for s in stamps]


def result(client, frames, value, status='ok', start=100.0, dur=2.0):
    return NS(round=1, client_id=client, status=status,
              capture_start=t(start), capture_end=t(start + dur),
              frames=frames, value=value, diagnostics=[
                  NS(key='min_confidence', value='0.5')])


def decision(outcome, winner, scores, clients=('left', 'right')):
    return NS(round=1, outcome=outcome, winner=winner, clients=list(clients),
              scores=list(scores), reason='')


def run(decisions, results, captured, aborted=None):
    return check_recording(decisions, results, captured, CONFIG, aborted)


def test_agreeing_round():
    # 15 joints at 1 m/s: 15 * (0.05**2/0.05) * 39 terms / 2 s = 14.625.
    # 0.1 m/s: 0.14625 (below min_expressiveness, still loses).
    captured = {'left': stream(1.0), 'right': stream(0.1)}
    results = [result('left', 40, 14.625), result('right', 40, 0.14625)]
    checks = run([decision('winner', 1, [14.625, 0.14625])], results,
                 captured)
    assert checks[0].ok, format_table(checks)
    assert checks[0].clients[0].value_recomputed == pytest.approx(14.625)
    assert 'recomputed winner (participant 1)' in format_table(checks)
    assert checks[0].clients[0].first_frame_offset == pytest.approx(0.01)
    assert 'spread 0.0 ms' in format_table(checks)


def test_tampered_score_is_caught():
    captured = {'left': stream(1.0), 'right': stream(0.1)}
    results = [result('left', 40, 14.0), result('right', 40, 0.14625)]
    checks = run([decision('winner', 1, [14.0, 0.14625])], results, captured)
    assert not checks[0].ok
    assert 'value 14 recorded' in checks[0].clients[0].problems[0]


def test_wrong_decision_is_caught():
    captured = {'left': stream(1.0), 'right': stream(2.0)}
    results = [result('left', 40, 14.625), result('right', 40, 58.5)]
    checks = run([decision('winner', 1, [14.625, 58.5])], results, captured)
    assert not checks[0].ok
    assert checks[0].winner_recomputed == 2
    assert 'MISMATCH' in format_table(checks)


def test_missing_captured_frames_are_caught():
    results = [result('left', 40, 14.625), result('right', 40, 0.14625)]
    checks = run([decision('winner', 1, [14.625, 0.14625])], results,
                 {'right': stream(0.1)})
    assert not checks[0].ok
    assert 'no captured frames' in checks[0].clients[0].problems[0]


def test_no_winner_and_missing_client():
    captured = {'left': stream(0.1)}
    results = [result('left', 40, 0.14625)]
    checks = run([decision('no_winner', 0, [0.14625, math.nan])], results,
                 captured)
    assert checks[0].ok, format_table(checks)


def test_round_aborted_by_control_module():
    checks = run([decision('aborted', 0, [math.nan, math.nan])], [], {},
                 aborted={1: 'right did not ACK'})
    assert checks[0].ok
    checks = run([decision('no_winner', 0, [math.nan, math.nan])], [], {},
                 aborted={1: 'right did not ACK'})
    assert not checks[0].ok
