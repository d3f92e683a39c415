"""Recompute recorded dance-off rounds and check them (no ROS).

The core of ``nodes/verify_decisions``. Messages are duck-typed (rospy
messages or ``rosbags`` dataclasses): for every recorded ``Decision`` it
takes the round's ``ClientResult`` of each participant, recomputes the
score from that client's ``/<client_id>/captured`` frames inside the
result's window, and recomputes the decision from the recomputed scores
with the decision module's rule and parameters. Reading a recording is
``hri_sync.tools``' part (``tools.bag``, ``tools.session``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

from hri_sync.decision.rule import (ABORTED, DEFAULT_NOISE_FACTOR, THRESHOLD,
                                    USABLE, decide)
from hri_sync.dance_off.expressiveness import SkeletonExpressiveness
from hri_sync.data_process.processors import Frame

REL_TOL = 1e-6
ABS_TOL = 1e-9


def seconds(t: Any) -> float:
    """A rospy.Time or a rosbags Time (sec, nanosec) in seconds."""
    if hasattr(t, 'to_sec'):
        return t.to_sec()
    return t.sec + t.nanosec * 1e-9


@dataclass
class ClientCheck:
    """One participant's recorded and recomputed result of a round."""

    client: str
    status: str
    frames: int = 0
    frames_recomputed: int = 0
    value: float = math.nan
    value_recomputed: float = math.nan
    first_frame_offset: float = math.nan    # s after the window start
    problems: list = field(default_factory=list)


@dataclass
class RoundCheck:
    """One round: the clients' checks and the two decisions."""

    round: int
    clients: list
    outcome: str
    winner: int
    outcome_recomputed: str = ''
    winner_recomputed: int = 0
    reason: str = ''
    problems: list = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not self.problems and not any(c.problems for c in self.clients)


def _close(a: float, b: float) -> bool:
    if math.isnan(a) and math.isnan(b):
        return True
    return math.isclose(a, b, rel_tol=REL_TOL, abs_tol=ABS_TOL)


def _processor(result: Any) -> SkeletonExpressiveness:
    """The result's processor again, with the params its diagnostics
    recorded (min_confidence, the participant zone)."""
    return SkeletonExpressiveness(**SkeletonExpressiveness.params_from(
        {kv.key: kv.value for kv in result.diagnostics}))


def check_client(result: Any, captured: list[Any]) -> ClientCheck:
    """Recompute one ClientResult from ``captured``: [(stamp, msg)] sorted."""
    check = ClientCheck(result.client_id, result.status,
                        frames=result.frames, value=result.value)
    start, end = seconds(result.capture_start), seconds(result.capture_end)
    frames = [Frame(s, m) for s, m in captured if start <= s < end]
    if not frames and result.frames:
        check.problems.append('no captured frames recorded for the window')
    res = _processor(result).process(
        frames, start, end)
    check.frames_recomputed = res.frames_used
    if frames:
        check.first_frame_offset = frames[0].stamp - start
    check.value_recomputed = res.value if frames else math.nan
    if result.status in USABLE:
        if res.frames_used != result.frames:
            check.problems.append('frames %d recorded, %d recomputed'
                                  % (result.frames, res.frames_used))
        if not _close(res.value, result.value):
            check.problems.append('value %.9g recorded, %.9g recomputed'
                                  % (result.value, res.value))
    return check


def check_round(decision: Any, results: dict[str, Any],
                captured: dict[str, list[tuple[float, Any]]],
                config: dict[str, str | float],
                aborted_reason: str | None = None) -> RoundCheck:
    """Check one recorded Decision.

    ``results``: {client_id: ClientResult} of the round; ``captured``:
    {client_id: [(stamp, msg)]}; ``config``: the decision module's
    ``min_expressiveness``, ``tie_margin``, ``on_missing`` and, when
    recorded, ``decision_rule``, ``noise_factor`` (the noise rule takes
    each result's recorded ``noise_floor`` and ``noise_source``: its
    quiet level comes from the sensor's stream outside the window, which
    the bag need not hold; a result without a floor, an older message,
    has it unknown, one without a source has it trusted, as the decision
    module that recorded it did);
    ``aborted_reason``: set when the control module aborted the round.
    """
    participants = list(decision.clients)
    check = RoundCheck(decision.round, [], decision.outcome, decision.winner,
                       reason=decision.reason)
    recomputed: dict[str, tuple] = {}
    for client in participants:
        result = results.get(client)
        if result is None:
            continue
        c = check_client(result, captured.get(client, []))
        check.clients.append(c)
        value = c.value_recomputed if result.status in USABLE \
            else math.nan
        recomputed[client] = (result.status, value,
                              getattr(result, 'noise_floor', math.nan),
                              getattr(result, 'noise_source', ''))
    for client, score in zip(participants, decision.scores):
        result = results.get(client)
        recorded = result.value if result is not None and \
            result.status in USABLE else math.nan
        if not _close(score, recorded):
            check.problems.append('decision score of %s %.9g differs from its '
                                  'result %.9g' % (client, score, recorded))
    if aborted_reason is not None:
        outcome, winner = ABORTED, 0
    else:
        verdict = decide(participants, recomputed,
                         float(config['min_expressiveness']),
                         float(config['tie_margin']),
                         str(config['on_missing']),
                         str(config.get('decision_rule', THRESHOLD)),
                         float(config.get('noise_factor',
                                          DEFAULT_NOISE_FACTOR)))
        outcome, winner = verdict.outcome, verdict.winner
    check.outcome_recomputed, check.winner_recomputed = outcome, winner
    if (outcome, winner) != (decision.outcome, decision.winner):
        check.problems.append('decision %s/%d recorded, %s/%d recomputed'
                              % (decision.outcome, decision.winner, outcome,
                                 winner))
    return check


def check_recording(decisions: list[Any], results: list[Any],
                    captured: dict[str, list[tuple[float, Any]]],
                    config: dict[str, str | float],
                    aborted: dict[int, str] | None = None) -> list[RoundCheck]:
    """Check every recorded decision.

    ``results``: list of ClientResult; ``captured``: {client_id: [(stamp,
    msg)]}; ``aborted``: {round: reason} from RoundStatus.
    """
    aborted = aborted or {}
    by_round: dict[int, dict[str, Any]] = {}
    for r in results:
        by_round.setdefault(r.round, {})[r.client_id] = r
    for frames in captured.values():
        frames.sort(key=lambda f: f[0])
    return [check_round(d, by_round.get(d.round, {}), captured, config,
                        aborted.get(d.round))
            for d in sorted(decisions, key=lambda d: d.round)]


def format_table(checks: list[RoundCheck]) -> str:
    """A plain-text table of the checks."""
    lines = ['round client   status   frames(rec/re)  value recorded   '
             'recomputed       check']
    for rc in checks:
        for c in rc.clients:
            lines.append('%5d %-8s %-8s %6d/%-6d  %15.9g  %15.9g  %s' % (
                rc.round, c.client, c.status, c.frames, c.frames_recomputed,
                c.value, c.value_recomputed,
                'ok' if not c.problems else 'MISMATCH: ' + '; '.join(
                    c.problems)))
        offsets = [c.first_frame_offset for c in rc.clients]
        if len(offsets) > 1 and all(map(math.isfinite, offsets)):
            lines.append('%5d first frames after the window start: %s; '
                         'spread %.1f ms' % (rc.round, ', '.join(
                             '%s %.1f ms' % (c.client,
                                             c.first_frame_offset * 1e3)
                             for c in rc.clients),
                             (max(offsets) - min(offsets)) * 1e3))
        lines.append('%5d decision: recorded %s%s, recomputed %s%s  %s' % (
            rc.round, rc.outcome,
            ' (participant %d)' % rc.winner if rc.winner else '',
            rc.outcome_recomputed,
            ' (participant %d)' % rc.winner_recomputed
            if rc.winner_recomputed else '',
            'ok' if not rc.problems else 'MISMATCH: ' + '; '.join(
                rc.problems)))
    return '\n'.join(lines)
