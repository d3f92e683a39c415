"""LSL out: hri_sync's round events as LSL markers (docs/lsl.md).

No ROS and no pylsl (``nodes/lsl_outlet`` holds the outlet).  Each event
is one string marker, a JSON object, stamped on the outlet host's LSL
clock at the event's global time: global -> this host's wall clock by the
node's clock model, -> LSL clock by this process's wall minus LSL clock.
The marker carries the global time and ``bound``, the error bound (s) of
its LSL stamp (the clock model's uncertainty then).
"""
import json
import math
from collections import Counter

EVENTS = ('sync', 'window_start', 'window_end', 'result', 'decision',
          'action_start', 'action_end', 'round_aborted')


def marker_text(event, round_id, global_time, bound, **fields):
    """The marker of one event: a JSON object (keys sorted)."""
    if event not in EVENTS:
        raise ValueError('unknown event %r' % event)
    return json.dumps(dict(fields, event=event, round=int(round_id),
                           global_time=round(global_time, 6),
                           bound=round(bound, 6)), sort_keys=True,
                      allow_nan=False)


def parse_marker(text):
    """A marker's JSON as a dict; ValueError when it is not ours."""
    d = json.loads(text)
    if not isinstance(d, dict) or d.get('event') not in EVENTS:
        raise ValueError('not an hri_sync marker: %r' % text[:80])
    return d


def finite_or_none(x):
    """JSON has no NaN: a non-finite number becomes None."""
    return x if isinstance(x, (int, float)) and math.isfinite(x) else None


def capture_events(round_id, cr_t, str_aft, dur, clients):
    """(event, global time, fields) of a capture order: the window's
    start (CR_T + STR_AFT) and end."""
    start = cr_t + str_aft
    return [('window_start', start, {'clients': list(clients),
                                     'dur': dur}),
            ('window_end', start + dur, {})]


class MarkerClock:
    """Global time -> this host's LSL clock, with the error bound.

    ``model``: a ClockModel (local wall -> global) or None before one;
    ``wall_minus_lsl``: this process's wall minus LSL clock.
    """

    def __init__(self):
        self.model = None

    def to_lsl(self, global_time, wall_minus_lsl):
        """(LSL stamp, bound); ValueError without a usable clock."""
        if self.model is None or not self.model.ready:
            raise ValueError('no clock model yet')
        local = self.model.to_local(global_time)
        bound = self.model.uncertainty_at(local)
        if not math.isfinite(bound):
            raise ValueError('the clock model has no bound')
        return local - wall_minus_lsl, bound


class Unread:
    """Markers pushed while no LSL consumer (LabRecorder) was connected:
    nobody recorded them.  Counted per round, reported once per round."""

    def __init__(self):
        self.by_round = Counter()
        self.reported = set()
        self.total = 0

    def pushed(self, round_id, consumers):
        """One marker of ``round_id`` pushed; ``consumers``: whether any
        was connected.  Returns the text to report, or ''."""
        if consumers:
            return ''
        self.by_round[round_id] += 1
        self.total += 1
        if round_id in self.reported:
            return ''
        self.reported.add(round_id)
        return ('round %d: markers pushed with no LSL consumer connected: '
                'no recorder (LabRecorder) has them' % round_id)

    def summary(self):
        """{round: unread markers} as text, newest 10 rounds."""
        rounds = sorted(self.by_round)[-10:]
        return ', '.join('%d: %d' % (r, self.by_round[r]) for r in rounds)
