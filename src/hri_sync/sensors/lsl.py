"""Lab Streaming Layer (LSL) streams in: stamps and the generic processor.

No ROS and no pylsl (``nodes/lsl_inlet`` holds the inlet; docs/lsl.md).
An LSL sample's timestamp is on its outlet host's LSL clock; the inlet
maps it to this host's LSL clock with LSL's own offset estimate
(``time_correction``), fitted with drift (``CorrectionFit``), and then to
this host's wall clock, which the DPM maps to global time with its clock
model (``stamp_source: host``).  ``LslStamper`` does the first two and
catches a stream whose clock resets; ``LslChannels`` is the DPM's
processor of the ``hri_sync/LslSample`` messages the inlet publishes.
"""
import math
from collections import deque

import numpy as np

from hri_sync.sensors.base import HeaderStamped, finite
from hri_sync.data_process.processors import ProcessResult
from hri_sync.wire.health import OK, WARN, Health, text
from hri_sync.wire.validate import Rejected

# hri_sync/LslSample kinds (the message's constants).
DATA, TICK, LOST, CLOCK_RESET, RECOVERED = range(5)
EVENTS = {LOST: 'lost', CLOCK_RESET: 'clock_reset', RECOVERED: 'recovered'}


def theil_sen(t, y):
    """(slope, intercept at t = 0) of the Theil-Sen line through the
    points: the median of the pairwise slopes, robust to an outlier."""
    t, y = np.asarray(t, float), np.asarray(y, float)
    if len(t) < 2:
        return 0.0, float(y[0])
    i, j = np.triu_indices(len(t), 1)
    dt = t[j] - t[i]
    keep = dt != 0
    slope = float(np.median((y[j] - y[i])[keep] / dt[keep])) \
        if keep.any() else 0.0
    return slope, float(np.median(y - slope * t))


class CorrectionFit:
    """LSL's clock offset to an outlet (``time_correction``: remote LSL
    time + correction = local LSL time), fitted with drift.

    ``add(local, correction, rtt)``: one estimate, made at local LSL time
    ``local``, with its round-trip time.  LSL re-estimates every few
    seconds; between estimates a drifting clock walks away from the last
    one (200 ppm: 0.4 ms in 2 s), so the map is the Theil-Sen line through
    those of the last ``keep`` estimates whose round trip is short
    (``used``; the drift fit LSL's docs suggest for post-processing, done
    live).  ``bound(local)``: half the round trip of the worst used
    estimate (an offset measured over a round trip is off by at most half
    of it), plus their median scatter about the line, plus the slope's
    own error (a round trip over the estimates' span) times the time from
    the last one.  With one used estimate the line is flat and the bound
    grows with ``drift_bound`` s/s from it.
    """

    def __init__(self, keep=12, drift_bound=5e-4):
        self.points = deque(maxlen=keep)
        self.drift_bound = drift_bound
        self.slope = 0.0
        self.intercept = math.nan
        self.ref = 0.0

    def add(self, local, correction, rtt=0.0):
        """One time_correction estimate (ignored when it repeats the
        last one, time and value: LSL returns its last estimate until the
        next)."""
        if not all(math.isfinite(v) for v in (local, correction, rtt)):
            raise ValueError('time correction %r at %r (rtt %r): not '
                             'finite' % (correction, local, rtt))
        if self.points and self.points[-1][:2] == (local, correction):
            return
        self.points.append((local, correction, max(0.0, rtt)))
        used = self.used()
        self.ref = float(self.points[-1][0])
        self.slope, self.intercept = theil_sen(
            [p[0] - self.ref for p in used], [p[1] for p in used])

    def used(self):
        """The estimates the line goes through: those whose round trip
        is within twice the least one's + 50 us (a loaded host's slow
        exchanges are the least certain: NTP's clock filter idea)."""
        least = min(p[2] for p in self.points)
        return [p for p in self.points if p[2] <= 2 * least + 50e-6]

    def reset(self):
        """Forget the estimates (the outlet's clock broke)."""
        self.points.clear()
        self.slope, self.intercept = 0.0, math.nan

    @property
    def ready(self):
        return bool(self.points)

    def correction(self, local):
        """The fitted correction at local LSL time ``local``."""
        return self.intercept + self.slope * (local - self.ref)

    def scatter(self):
        """Median distance (s) of the used estimates from the line."""
        used = self.used()
        if len(used) < 3:
            return 0.0
        return float(np.median([abs(c - self.correction(t))
                                for t, c, _ in used]))

    def bound(self, local):
        """Error bound (s) of ``correction(local)``."""
        if not self.points:
            return math.inf
        used = self.used()
        rtt = max(p[2] for p in used)
        last = used[-1][0]
        span = last - used[0][0]
        if len(used) == 1 or span <= 0:
            return rtt / 2 + self.drift_bound * abs(local - last)
        # The slope is off by up to a round trip over the span: that much
        # per second from the last estimate.
        return rtt / 2 + self.scatter() + rtt / span * abs(local - last)


class ClockBreak(Exception):
    """A sample's LSL stamp breaks with the stream's clock (``reason``)."""


class LslStamper:
    """Maps an LSL sample's stamp to this host's wall clock and catches a
    stream whose clock resets.

    ``stamp(lsl_stamp, now_lsl, wall_minus_lsl)`` -> (host stamp, error
    bound): the stamp plus the fitted correction is the sample's local
    LSL time (at most ``now_lsl``, when it was pulled, plus ``ahead`` s);
    plus ``wall_minus_lsl`` (this process's wall minus LSL clock, read
    together) it is on the host's wall clock.  A stamp that goes back by
    more than ``ahead`` s, or maps into the future, raises ClockBreak:
    the stream is ``broken`` and its samples are refused until
    ``settle`` in a row map consistently again: not into the future and
    lagging their pull by no more than 1.5 times the largest lag of the
    last 64 good samples plus ``min_lag`` s (LSL's next estimate
    corrected an outlet host clock that stepped).  A stream whose own
    stamps were reset stays broken: its samples have no known time.  (A
    reset back by less than the stream's delivery lag cannot be told from
    delivery jitter.)
    """

    def __init__(self, fit, ahead=0.005, settle=5, min_lag=0.02):
        self.fit = fit
        self.ahead = ahead
        self.settle = settle
        self.min_lag = min_lag
        self.last = None        # the last accepted sample's LSL stamp
        self.broken = ''        # why, while the stream's clock is broken
        self._good = 0
        self._lags = deque(maxlen=64)   # accepted samples' delivery lags

    @property
    def max_lag(self):
        """The most a consistent sample may lag behind its pull (s)."""
        return 1.5 * max(self._lags, default=0.0) + self.min_lag

    def _check(self, lsl_stamp, local, now_lsl):
        if not math.isfinite(lsl_stamp):
            return 'a stamp that is not finite (%r)' % lsl_stamp
        if not self.broken and self.last is not None and \
                lsl_stamp < self.last - self.ahead:
            return 'the stamp went back %.6f s' % (self.last - lsl_stamp)
        if local > now_lsl + self.ahead:
            return 'the stamp maps %.6f s into the future' % (
                local - now_lsl)
        if self.broken and now_lsl - local > self.max_lag:
            return 'the stamp maps %.3f s before its delivery' % (
                now_lsl - local)
        return ''

    def stamp(self, lsl_stamp, now_lsl, wall_minus_lsl):
        if not self.fit.ready:
            raise ClockBreak('no time correction estimate yet')
        local = lsl_stamp + self.fit.correction(now_lsl)
        why = self._check(lsl_stamp, local, now_lsl)
        if self.broken:
            self._good = 0 if why else self._good + 1
            if self._good < self.settle:
                raise ClockBreak(self.broken)
            self.broken = ''
        elif why:
            self.broken = why
            self._good = 0
            raise ClockBreak(why)
        self.last = lsl_stamp
        self._lags.append(max(0.0, now_lsl - local))
        return local + wall_minus_lsl, self.fit.bound(now_lsl)


class StreamGaps:
    """What a regular LSL stream delivered: samples, bursts and real gaps.

    ``deliver(stamps, pulled)``: the LSL stamps of the samples one pull
    brought, at local LSL time ``pulled`` (in stream order).

    A **burst** is a delivery of two or more samples after a silence of
    more than ``burst_periods`` nominal periods (at least ``min_silence``
    s): the stream stalled, then caught up.  A burst loses nothing, but an
    outlet that stamps its samples when it pushes them (LSL's default)
    bunches their stamps, so their spacing says nothing of a loss.

    A **real gap** is judged on the stream's sample clock instead: its
    j-th sample is due at ``base + j / rate``, and no sample is stamped
    before it was taken, so ``stamp - j / rate`` lies on ``base`` or
    above it: less than a period above for the last sample of a push
    (taken within a period before it), more only for the samples an
    outlet that fell behind still catches up with.  Once every sample of
    ``horizon`` s of stamps lies ``1 - slack`` periods or more above
    ``base``, floor(rise x rate + ``slack``) samples were lost there
    (``gaps`` once, ``lost`` by that many; the rise is the lowest of its
    last half horizon).  ``base`` is the lowest value
    of each ``horizon``: it follows a device a little slower or faster
    than its nominal rate.  Not seen: a single lost sample of a stream
    whose stamps jitter by more than ``slack`` periods; seen as a gap: an
    outlet stamping when it pushes whose push latency grows by a period
    for good.  An irregular stream (rate 0) has neither.
    """

    def __init__(self, rate, horizon=2.0, burst_periods=3.0,
                 min_silence=0.02, slack=0.1):
        self.period = 1.0 / rate if rate > 0 else math.nan
        self.horizon = horizon
        self.slack = slack
        self.silence = max(burst_periods * self.period, min_silence) \
            if rate > 0 else math.inf
        self.samples = self.bursts = self.largest_burst = 0
        self.gaps = self.lost = 0
        self._index = 0             # received samples plus those lost
        self._base = None           # the sample clock: stamp - index * P
        self._block = None          # (first stamp, lowest x) of a horizon
        self._rise = None           # [(stamp, lowest x)] above it, by bin
        self._delivered = None      # local LSL time of the last delivery

    def deliver(self, stamps, pulled):
        """One pull's samples (their LSL stamps) at local time ``pulled``."""
        if not len(stamps):
            return
        self.samples += len(stamps)
        if len(stamps) >= 2 and self._delivered is not None and \
                pulled - self._delivered > self.silence:
            self.bursts += 1
            self.largest_burst = max(self.largest_burst, len(stamps))
        self._delivered = pulled
        if math.isfinite(self.period):
            for stamp in stamps:
                self._on_clock(stamp, stamp - self._index * self.period)
                self._index += 1

    def restart(self):
        """The stream's stamps broke (a clock reset): a new sample clock."""
        self._index = 0
        self._base = self._block = self._rise = None

    def _on_clock(self, stamp, x):
        """Sample at ``stamp`` lying ``x - base`` s above the clock."""
        if self._base is None or \
                x < self._base + (1 - self.slack) * self.period:
            self._rise = None
            if self._base is None or x < self._base:
                self._base = x
            first, low = self._block or (stamp, x)
            self._block = (first, min(low, x))
            if stamp - first >= self.horizon:
                self._base, self._block = self._block[1], (stamp, x)
            return
        # The lowest x of each quarter horizon since the rise began.
        bins = self._rise = self._rise or [(stamp, x)]
        if stamp - bins[-1][0] >= self.horizon / 4:
            bins.append((stamp, x))
        bins[-1] = (bins[-1][0], min(bins[-1][1], x))
        if stamp - bins[0][0] >= self.horizon:
            # The level it settled at: the last half horizon's (the first
            # samples of a rise may be a push's, less than a gap above).
            level = min(low for t, low in bins
                        if t >= stamp - self.horizon / 2)
            lost = max(1, math.floor((level - self._base) / self.period
                                     + self.slack))
            self.gaps += 1
            self.lost += lost
            self._index += lost
            self._base = level - lost * self.period
            self._rise, self._block = None, (stamp, self._base)


def inlet_health(stream, gaps, fit, now_lsl, counts):
    """The LSL inlet's ``lsl`` status: ``stream`` (its description, ''
    while not resolved), its ``StreamGaps``, its ``CorrectionFit`` (the
    stream-level mapping quality: the fit's scatter and bound now, at
    local LSL time ``now_lsl``) and the inlet's ``counts``
    (dropped_clock, lost).  WARN with real gaps, dropped samples or a
    lost stream; bursts alone are OK."""
    scatter = fit.scatter() * 1e3 if fit.ready else math.nan
    bound = fit.bound(now_lsl) * 1e3 if fit.ready else math.inf
    values = (
        ('stream', stream or 'none'),
        ('samples_received', str(gaps.samples)),
        ('real_gaps', str(gaps.gaps)),
        ('samples_lost_in_gaps', str(gaps.lost)),
        ('bursts', str(gaps.bursts)),
        ('largest_burst', str(gaps.largest_burst)),
        ('dropped_clock', str(counts.get('dropped_clock', 0))),
        ('lost_count', str(counts.get('lost', 0))),
        ('fit_estimates', str(len(fit.used()) if fit.ready else 0)),
        ('fit_scatter_ms', text(scatter, '%.4f')),
        ('fit_bound_ms', text(bound, '%.4f')),
        ('fit_drift_ppm', text(fit.slope * 1e6 if fit.ready else math.nan,
                               '%.1f')))
    if not stream:
        return Health(WARN, 'no LSL stream resolved yet', values)
    bad = ['%d real gaps (%d samples lost)' % (gaps.gaps, gaps.lost)
           if gaps.gaps else '',
           '%d samples dropped (clock breaks)' % counts['dropped_clock']
           if counts.get('dropped_clock') else '',
           'stream lost %d times' % counts['lost']
           if counts.get('lost') else '']
    bad = [b for b in bad if b]
    message = '%d samples, %d bursts, mapping bound %.3f ms' % (
        gaps.samples, gaps.bursts, bound)
    return Health(WARN if bad else OK, '; '.join(bad + [message]), values)


class LslChannels(HeaderStamped):
    """The generic processor of an LSL stream (``hri_sync/LslSample``
    from ``nodes/lsl_inlet``): counts the window's samples and gives each
    numeric channel's mean; for a marker stream, the markers.

    ``measure: count`` (default): value = the number of samples in the
    window; ``measure: activity``: the RMS deviation of the channel
    vector from its window mean, sqrt(mean |x - mean(x)|^2), in the
    channels' unit (ImuActivity's measure, for an LSL accelerometer or any
    numeric stream; NaN without numeric samples).  Diagnostics:
    ``channel_means`` (numeric), ``activity``, ``samples``, ``markers``
    (the first 20 of a string stream, with their offsets from the window
    start), ``rate`` (Hz), and
    ``lsl_stream`` = ``lost: ...`` / ``clock_reset: ...`` when the inlet
    reported its stream lost or its clock broken in the window (each
    event in ``lsl_events``).  Stamps are on the host clock
    (``host_stamped``), each with its mapping's error bound.

    A regular stream's window is judged on its nominal rate (each
    sample's ``nominal_rate``), not on its stamps' spacing: an outlet
    that stamps its samples when it pushes them bunches the stamps of a
    burst.  ``expected`` = floor(window length x rate) samples; the
    coverage is received / expected (at most 1) and the dropped samples
    the smaller of what the gaps between stamps hold (``round(gap x
    rate) - 1`` each) and the deficit less the largest bunch of stamps
    (closer than half a period) the window holds: a burst that catches up
    misses nothing, and the samples a burst carries past the window's end
    (at most about a bunch) were not lost.  A real loss in a stream
    stamped in bunches is so counted short by up to a bunch.
    """

    msg_type = 'hri_sync/LslSample'
    topic = 'lsl'
    host_stamped = True

    def __init__(self, measure='count'):
        super().__init__()
        if measure not in ('count', 'activity'):
            raise ValueError("measure must be count or activity, got %r"
                             % (measure,))
        self.measure = measure
        self.begin(0.0, 0.0)

    def stamp_error(self, msg):
        return msg.stamp_error if math.isfinite(msg.stamp_error) else 0.0

    def check(self, msg):
        if msg.kind not in (DATA, TICK) and msg.kind not in EVENTS:
            raise Rejected('malformed', 'LslSample kind %r' % msg.kind,
                           'kind')
        finite(list(msg.channels), 'channels')
        if not (msg.stamp_error >= 0):
            raise Rejected('malformed', 'stamp_error %r' % msg.stamp_error,
                           'stamp_error')

    def begin(self, start, end):
        self._start, self._duration = start, end - start
        self._n = 0
        self._sums = None
        self._sum2 = 0.0
        self._numeric = 0
        self._markers = []
        self._events = []
        self._rate = 0.0          # the stream's nominal rate (Hz)
        self._last = None         # the last sample's stamp
        self._gap_drops = 0       # what the stamps' gaps hold
        self._bunch = self._largest_bunch = 0   # stamps closer than P / 2

    def add(self, frame):
        msg = frame.msg
        if msg.kind == TICK:
            return
        if msg.kind in EVENTS:
            self._events.append('%s at %+.3f s: %s' % (
                EVENTS[msg.kind], frame.stamp - self._start, msg.reason))
            return
        self._n += 1
        if msg.nominal_rate > 0:
            self._rate = msg.nominal_rate
            gap = math.inf if self._last is None else \
                (frame.stamp - self._last) * self._rate
            if math.isfinite(gap):
                self._gap_drops += max(0, round(gap) - 1)
            self._bunch = self._bunch + 1 if gap < 0.5 else 1
            self._largest_bunch = max(self._largest_bunch, self._bunch)
            self._last = frame.stamp
        if msg.channels:
            v = np.asarray(msg.channels, float)
            if self._sums is None or len(self._sums) != len(v):
                self._sums = np.zeros(len(v))
                self._sum2 = 0.0
                self._numeric = 0
            self._sums += v
            self._sum2 += float(v @ v)
            self._numeric += 1
        if msg.markers and len(self._markers) < 20:
            self._markers.append('%+.4f %s' % (frame.stamp - self._start,
                                               '|'.join(msg.markers)))

    def result(self):
        d = {'unit': 'samples', 'rate': (self._n / self._duration
                                         if self._duration > 0 else 0.0)}
        activity = math.nan
        if self._numeric:
            mean = self._sums / self._numeric
            d['channel_means'] = ' '.join('%.6g' % m for m in mean)
            activity = math.sqrt(max(0.0, self._sum2 / self._numeric
                                     - float(mean @ mean)))
            d['activity'] = activity
        d['samples'] = self._n
        if self._markers:
            d['markers'] = '; '.join(self._markers)
        if self._events:
            d['lsl_events'] = '; '.join(self._events)
            bad = [e for e in self._events if not e.startswith('recovered')]
            if bad:
                d['lsl_stream'] = bad[-1]
        if self.measure == 'activity':
            d['unit'] = 'channel units (RMS)'
        coverage, dropped = self._sample_clock(d)
        return ProcessResult(
            value=activity if self.measure == 'activity' else float(self._n),
            frames_used=self._n, diagnostics=d, coverage=coverage,
            frames_dropped=dropped)

    def _sample_clock(self, d):
        """(coverage, dropped) on the nominal rate (NaN, None: an
        irregular stream, judged by the DPM on its stamps)."""
        expected = math.floor(self._duration * self._rate + 1e-6)
        if expected <= 0:
            return math.nan, None
        d['nominal_rate'] = self._rate
        d['expected_samples'] = expected
        held = self._largest_bunch if self._largest_bunch > 1 else 0
        d['largest_bunch'] = held
        return (min(1.0, self._n / expected),
                min(max(0, expected - self._n - held), self._gap_drops))
