"""The decision module's rule: who was the most expressive?

No ROS.  Participant numbers count from 1 in the order of ``participants``.
"""
import math
from dataclasses import dataclass

WINNER, NO_WINNER, TIE, ABORTED = 'winner', 'no_winner', 'tie', 'aborted'
USABLE = ('ok', 'partial')   # ClientResult statuses that carry a score


@dataclass
class Verdict:
    """A decision, in the fields of hri_sync/Decision."""

    outcome: str
    winner: int          # participant number from 1; 0 for none
    scores: list         # per participant, NaN where no usable result
    reason: str


def decide(participants, results, min_value=0.0, tie_margin=0.0,
           on_missing='partial'):
    """Decide a round.

    ``results`` maps client_id -> (status, value).  A participant without a
    usable result (missing, late, no data, error, non-finite value) is left
    out of the comparison; ``on_missing`` is 'partial' (decide over those
    present, saying so in the reason) or 'abort'.  The largest score wins;
    ``no_winner`` when every score is below ``min_value``; ``tie`` when the
    best two are within ``tie_margin``.
    """
    if on_missing not in ('partial', 'abort'):
        raise ValueError("~on_missing must be 'partial' or 'abort', got %r"
                         % (on_missing,))
    scores, problems = [], []
    for c in participants:
        status, value = results.get(c, ('missing', math.nan))
        if status in USABLE and math.isfinite(value):
            scores.append(float(value))
            if status != 'ok':
                problems.append('%s result is %s' % (c, status))
        else:
            scores.append(math.nan)
            problems.append('%s has no usable result (%s)' % (c, status))
    present = [(s, i) for i, s in enumerate(scores) if math.isfinite(s)]
    note = ('; '.join(problems) + ': decided over the clients present'
            if problems else '')
    if not present:
        return Verdict(ABORTED, 0, scores, 'no usable result: '
                       + '; '.join(problems))
    if any(not math.isfinite(s) for s in scores) and on_missing == 'abort':
        return Verdict(ABORTED, 0, scores, '; '.join(problems)
                       + ' (~on_missing: abort)')
    ranked = sorted(present, reverse=True)
    best, best_i = ranked[0]
    suffix = (' [partial: %s]' % note) if note else ''
    if best < min_value:
        return Verdict(NO_WINNER, 0, scores,
                       'every score is below min_expressiveness %.4g'
                       % min_value + suffix)
    if len(ranked) > 1 and best - ranked[1][0] <= tie_margin:
        return Verdict(TIE, 0, scores, 'best two scores %.4g and %.4g are '
                       'within tie_margin %.4g' % (best, ranked[1][0],
                                                   tie_margin) + suffix)
    return Verdict(WINNER, best_i + 1, scores, '%s scored highest (%.4g)'
                   % (participants[best_i], best) + suffix)
