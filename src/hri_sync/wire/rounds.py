"""One rule for an order of a round that came before (no ROS).

The CM orders each round once (capture_data), and a CPM its DPM once per
round (capture_command).  So a module that gets a second order of a
round judges it by the windows that round was taken with before:

- the same window again is a repeat ('duplicate'), ignored;
- another window while the round is still open ('conflicting') is
  ignored: the round keeps the window it is capturing or collecting;
- another window for a round already closed ('conflicting') is taken:
  one of the two orders was not the rightful sender's (a forged one
  under its caller id), and dropping the later one as a repeat would
  lose the real round.

The DM (``decision.rule.RoundCollector``, by window end) and the DPM
(``data_process.dpm.DataProcess``, by start and end) both follow it,
each with a ``RoundWindows``: every window each round was taken with.
"""

from __future__ import annotations

import math
from typing import Collection

DUPLICATE = 'duplicate'
CONFLICTING = 'conflicting'


def repeated_order(window: tuple[float, ...],
                   known: Collection[tuple[float, ...]],
                   is_open: bool) -> tuple[str, bool]:
    """(why, take) for an order of a round with ``window``.

    ``known``: the windows the round was taken with before (empty: a new
    round; a window with a part that is not finite, e.g. a round aborted
    before its order, counts as the same window); ``is_open``: the round
    is still open.  ``why`` is '' for a new round, else DUPLICATE or
    CONFLICTING; ``take`` tells whether to open the round with
    ``window``.
    """
    if not known:
        return '', True
    if window in known or not all(math.isfinite(x)
                                  for k in known for x in k):
        return DUPLICATE, False
    return CONFLICTING, not is_open


class RoundWindows:
    """The windows each of the last ``remember`` rounds taken was taken
    with, judged by ``repeated_order``."""

    def __init__(self, remember: int = 100) -> None:
        self.remember = remember
        self.windows: dict[int, list[tuple[float, ...]]] = {}

    def take(self, round_id: int, window: tuple[float, ...],
             is_open: bool) -> tuple[str, bool]:
        """(why, take) for an order of ``round_id`` with ``window``
        (``repeated_order``); a window taken is remembered."""
        why, take = repeated_order(window, self.windows.get(round_id, []),
                                   is_open)
        if take:
            self.note(round_id, window)
        return why, take

    def note(self, round_id: int, window: tuple[float, ...]) -> None:
        """Remember that ``round_id`` had ``window`` (NaN parts: a round
        that ended without one, e.g. aborted before its order)."""
        self.windows.setdefault(round_id, []).append(window)
        while len(self.windows) > self.remember:
            del self.windows[next(iter(self.windows))]  # the oldest
