"""The data capture/process module (DPM) as a state machine.

No ROS and no clock read: the shell passes each sample's local arrival
time, and the local time of each poll.  ``DataProcess`` stamps samples in
global time (a ``TimeMapping`` chosen by ``stamp_source``), runs one
``CaptureWindow`` per capture command, tells which samples were captured
(to republish) and returns each window's result as soon as the window is
complete: a sample stamped at or after its end has arrived, or the
sensor's observed period plus a margin has passed its end with nothing
more.  Every window carries an error bound on its stamps.
"""

from __future__ import annotations

import math
from collections import Counter, deque
from dataclasses import dataclass, field
from typing import Any, Callable

from hri_sync.data_process.capture import (ERROR, CaptureWindow, SampleBuffer,
                                           window_stats)
from hri_sync.clock.model import ClockModel
from hri_sync.data_process.mapping import (ArrivalStamps, DeviceClockMapper,
                                           TimeMapping)
from hri_sync.data_process.noise_floor import (DEFAULT_CHUNK, DEFAULT_SPAN,
                                               Calibration, QuietBaseline)
from hri_sync.data_process.processors import Processor
from hri_sync.wire.rounds import RoundWindows
from hri_sync.wire.times import DeviceTime, GlobalTime, LocalTime
from hri_sync.wire.validate import Rejected
from hri_sync.wire.vocabulary import (CALIBRATION_ROUND, COMPLETION_MARGIN,
                                      DRIFT_BOUND, MIN_COVERAGE,
                                      ResultStatus)

STAMP_SOURCES = ('auto', 'arrival', 'device', 'host')


@dataclass
class WindowResult:
    """A window's outcome, in the fields of hri_sync/ClientResult."""

    round: int
    status: str
    start: float
    end: float
    frames: int = 0
    frames_rejected: int = 0
    frames_dropped: int = 0
    coverage: float = 0.0
    first_frame_offset: float = math.nan
    wake_lateness: float = math.nan
    value: float = math.nan
    timing_uncertainty: float = math.nan
    noise_floor: float = math.nan   # in the value's unit; NaN: unknown
    diagnostics: dict = field(default_factory=dict)
    noise_source: str = ''          # a NoiseSource value; '': no floor

    @property
    def calibration(self) -> bool:
        """True for the result of a calibration window (``calibrate``)."""
        return self.round == CALIBRATION_ROUND


@dataclass
class Step:
    """What one input made happen: samples captured (to republish, as
    (global stamp, msg, raw)), windows completed (WindowResults), and
    rounds whose already-published window a late sample would have
    belonged to."""

    captured: list = field(default_factory=list)
    results: list = field(default_factory=list)
    late: list = field(default_factory=list)


class DataProcess:
    """Stamps samples, runs capture windows and decides when each is done.

    ``make_processor()`` returns a fresh Processor for each window.
    ``stamp_source``: 'arrival', 'device', 'host' or 'auto' (host when
    the processor says its device stamps are already on this host's
    clock, ``host_stamped``; device when it reads device stamps).  A host
    stamp (a bridge that mapped it, e.g. ``nodes/lsl_inlet``) is mapped
    by the clock model alone; one not finite, not positive, or after its
    own arrival by more than ``jump`` s is rejected (``bad_device_stamp``);
    the processor's ``stamp_error(msg)`` is added to its error bound.
    Device stamps that are zero, not finite, or break with the device
    clock map (going back, or mapping after their own arrival by more than
    ``jump`` s) are held: if they and the next samples continue them for
    ``settle`` samples (later on the device clock, none delivered more
    than ``jump`` s quicker than the quickest of them: a starved sensor's
    delivery may be slower by any amount), the device clock was restarted
    and the map starts over; otherwise they are rejected and counted
    (``bad_device_stamp``), and the map keeps going.
    The first samples of a map wait until it holds ``settle`` samples and
    are then stamped with it (``settling`` counts them).  The map is
    refitted with every sample up to 1 / ``refit`` Hz, then every
    ``refit`` s of device time (a fit costs O(samples in its 30 s)).

    The error bound of a sample's stamp is the clock model's uncertainty
    grown by ``drift_bound`` s/s from the model's last NTP measurement
    (``ClockModel.uncertainty_at``; the CPM's own convention, conservative
    in a holdover, whose published uncertainty has grown already); a
    window's bound is its worst sample's (its end's, without samples) plus
    the device map's residual, plus every move of the map towards earlier
    stamps while the window's samples were stamped (``device_map_shift``,
    over ``device_map_moves`` moves): a sample stamped before such a move
    of s seconds was stamped s late, and the window may hold s x rate
    samples more than its span, plus one per move (each move splits the
    device times it holds into one stretch more, with two ends).

    A window is due for lack of samples ``margin`` s, plus the recent
    delivery lag of device-stamped samples, after the next sample was
    expected past its end.  With ``complete_on_last`` it is complete as
    soon as a sample stamped in it comes less than the least of the
    sensor's last 31 stamp spacings (once there are 8, none of them a
    repeated stamp) before its end: the next one is due after the end (a
    frame period sooner than waiting for it).  ``min_rate`` (Hz; 0: none)
    is the lowest rate at which the sensor's samples still cover a window:
    slower, even if evenly (a tracker starved of CPU), the window is
    judged at that rate (``window_stats``' ``max_period``) and is partial.

    Every sample is first validated by the processor's ``check``: one it
    rejects is counted by its reason (``counts``, ``invalid``, and the
    window its arrival falls in, whose result counts it in
    ``frames_rejected`` and ``invalid_<reason>``), never stamped.

    Each result carries the value's noise floor on this sensor
    (``hri_sync.data_process.noise_floor``): the larger of the window's own
    estimate (the processor's ``noise_floor``) and, for a processor with
    ``quiet_baseline``, the quiet level: the score of the last calibration
    window (``calibrate``: the CM's, nobody moving) with status ok, or
    without one the lowest value of its ``noise_chunk`` s stretches of
    every stamped sample of the last ``noise_span`` s (``noise_source``
    says which).
    """

    def __init__(
            self,
            make_processor: Callable[[], Processor],
            stamp_source: str = 'auto', min_coverage: float = MIN_COVERAGE,
            history: float = 2.0, margin: float = COMPLETION_MARGIN,
            reorder: float = 0.2, drift_bound: float = DRIFT_BOUND,
            jump: float = 0.1, refit: float = 0.05,
            min_rate: float = 0.0, noise_chunk: float = DEFAULT_CHUNK,
            noise_span: float = DEFAULT_SPAN,
            complete_on_last: bool = True) -> None:
        if stamp_source not in STAMP_SOURCES:
            raise ValueError('stamp_source must be one of %s, got %r'
                             % (', '.join(STAMP_SOURCES), stamp_source))
        probe = make_processor()
        self.make_processor = make_processor
        self.read_device_stamp = probe.device_stamp
        self.check = probe.check
        self.invalid: Counter[str] = Counter()  # check's rejects, by reason
        self.last_invalid = ''       # the last one's message
        if stamp_source == 'auto':
            stamp_source = ('host' if probe.host_stamped else 'arrival'
                            if type(probe).device_stamp
                            is Processor.device_stamp else 'device')
        self.stamp_error = probe.stamp_error
        # the global [start, end) of the rounds' windows (not the
        # calibration's), for the quiet baseline to tell its stretches in
        # them (a participant's pause) from the others
        self._spans: deque[tuple[float, float]] = deque(maxlen=256)
        self.baseline = QuietBaseline(
            make_processor, noise_chunk, noise_chunk / 4.0, noise_span,
            busy=lambda a, b: any(s < b and a < e for s, e in self._spans)) \
            if probe.quiet_baseline else None
        self.calibration = Calibration()
        self.stamp_source = stamp_source
        self.mapping: TimeMapping[Any] = ArrivalStamps()
        if stamp_source == 'device':
            self.mapping = DeviceClockMapper()
        if not (math.isfinite(min_rate) and min_rate >= 0):
            raise ValueError('min_rate must be >= 0 Hz, got %r' % min_rate)
        self.max_period = 1.0 / min_rate if min_rate else math.nan
        self.min_coverage = min_coverage
        self.margin = margin
        self.complete_on_last = complete_on_last
        self.reorder = reorder
        self.drift_bound = drift_bound
        self.jump = jump
        self.refit = refit
        self._fitted = -math.inf    # device stamp of the map's last fit
        self.clock: ClockModel | None = None
        self.history = SampleBuffer(history)
        self.windows: dict[int, CaptureWindow] = {}
        self.rounds = RoundWindows()      # every window each round had
        # (round, start, end) published
        self.closed: deque[tuple[int, float, float]] = deque(maxlen=16)
        self.counts: Counter[str] = Counter()
        # (device, arrival, local, msg, raw): a jump, then the same held
        # until the map is ready
        self._pending: list[tuple] = []
        self._settling: list[tuple] = []
        self._gaps: deque[float] = deque(maxlen=31)
        self._steps: deque[float] = deque(maxlen=31)  # repeats too
        self._lags: deque[float] = deque(maxlen=32)
        self._last_stamp: float | None = None
        # (arrival, s): each move of the device map to stamps s earlier
        self._shifts: deque[tuple[float, float]] = deque(maxlen=256)

    # -- clock and stamps -------------------------------------------------

    def set_clock(self, model: Any) -> None:
        """Use ClockModel ``model`` (local -> global) from now on."""
        self.clock = ClockModel(model.local_ref, model.offset, model.drift,
                                model.uncertainty, self.drift_bound)

    def clock_bound(self, local: LocalTime) -> float:
        """Error bound (s) of the global time of local time ``local``
        (infinite without a clock)."""
        if self.clock is None:
            return math.inf
        return self.clock.uncertainty_at(local)

    @property
    def period(self) -> float:
        """The sensor's observed period: the median of its recent positive
        stamp spacings (NaN until there are some)."""
        if not self._gaps:
            return math.nan
        return sorted(self._gaps)[len(self._gaps) // 2]

    @property
    def least_gap(self) -> float:
        """The least of the sensor's last 31 stamp spacings, once there
        are 8; NaN before, when a stamp was repeated or went back among
        them (the next sample may be stamped as the last), or without
        ``complete_on_last``."""
        if not self.complete_on_last or len(self._steps) < 8 or \
                min(self._steps) <= 0:
            return math.nan
        return min(self._steps)

    @property
    def lag(self) -> float:
        """How late after their stamps samples arrive: the second largest
        of the last 32 (0 for arrival stamps; one stall does not count)."""
        if len(self._lags) < 2:
            return 0.0
        return sorted(self._lags)[-2]

    def _reject(self, reason: str, arrival: float | None = None) -> None:
        self.counts[reason] += 1
        if arrival is not None:
            for w in self.windows.values():
                if w.start <= arrival < w.end:
                    w.rejected[reason] += 1

    def _stamp_device(self, msg: Any, raw: bytes | None,
                      arrival: GlobalTime, local: LocalTime) -> list[Any]:
        """[(stamp, msg, raw, arrival, local)] of the samples this one
        stamps: none while it is held, itself, or those held before it
        too."""
        try:
            device = self.read_device_stamp(msg)
        except (AttributeError, TypeError, ValueError):
            device = None
        if device is None or not math.isfinite(device):
            self._reject('no_device_stamp', arrival)
            return []
        if device <= 0:
            self._reject('bad_device_stamp', arrival)
            return []
        sample = (device, arrival, local, msg, raw)
        m = self.mapping
        assert isinstance(m, DeviceClockMapper)  # stamp_source 'device'
        last = m.last_device
        if last is not None and not (
                device >= last and
                m.to_global(DeviceTime(device)) <= arrival + self.jump):
            return self._held(sample)
        self._drop_pending(arrival)
        stamping = m.ready      # (none stamped by a map that settles)
        m.add(DeviceTime(device), arrival)
        if not (m.ready and 0 <= device - self._fitted < self.refit):
            # add kept the last fit: this stamp, before and after the refit
            before = m.to_global(DeviceTime(device)) if stamping else None
            m.refit()
            self._fitted = device
            if before is not None:
                moved = before - m.to_global(DeviceTime(device))
                if moved > 0:
                    self._shifts.append((arrival, moved))
        self._settling.append(sample)
        if not m.ready:
            # Alone, a sample that arrived late would set the map's offset
            # that late: held until the fit has ``settle`` samples.
            self.counts['settling'] += 1
            return []
        return self._release(self._settling)

    def _stamp_host(self, msg: Any, raw: bytes | None, arrival: GlobalTime,
                    local: LocalTime) -> list[Any]:
        """[(stamp, msg, raw, arrival, local)] of a sample whose device
        stamp is on this host's clock: mapped by the clock model."""
        assert self.clock is not None     # on_sample checked it
        try:
            read = self.read_device_stamp(msg)
            host = math.nan if read is None else float(read)
        except (AttributeError, TypeError, ValueError):
            host = math.nan
        if not math.isfinite(host):
            self._reject('no_device_stamp', arrival)
            return []
        stamp = self.clock.to_global(LocalTime(host))
        if host <= 0 or stamp > arrival + self.jump:
            self._reject('bad_device_stamp', arrival)
            return []
        return [(stamp, msg, raw, arrival, local)]

    def _release(self, held: list[tuple]) -> list[tuple]:
        """Stamp ``held`` samples with the map as it is now."""
        self._settling = []
        return [(self.mapping.to_global(d), msg, r, a, t)
                for d, a, t, msg, r in held]

    def _held(self, sample: tuple) -> list[Any]:
        """A device stamp that breaks with the map: garbage, or the first
        sample of a restarted device clock (confirmed by ``settle`` that
        continue it, when the map starts over and stamps them all)."""
        pending = self._pending
        assert isinstance(self.mapping, DeviceClockMapper)
        device, arrival = sample[:2]
        if pending:
            # Continued as a map of the held samples would take it: later
            # on the device clock, and not quicker than their least delay
            # by more than ``jump`` (any slower delivery is a delay).
            base = min(p[1] - p[0] for p in pending)
            if device >= pending[-1][0] and \
                    (arrival - device) - base >= -self.jump:
                pending.append(sample)
                if len(pending) < self.mapping.settle:
                    return []
                for _ in self._settling:   # of a map that never settled
                    self._reject('bad_device_stamp', arrival)
                self.mapping.reset()
                for p in pending:
                    self.mapping.observe(p[0], p[1])
                self.counts['settling'] += len(pending) - 1
                self._pending = []
                return self._release(pending)
            self._drop_pending(arrival)
        self._pending = [sample]
        return []

    def _drop_pending(self, arrival: float) -> None:
        for _ in self._pending:
            self._reject('bad_device_stamp', arrival)
        self._pending = []

    # -- inputs -----------------------------------------------------------

    def on_sample(self, msg: Any, local: LocalTime,
                  raw: bytes | None = None) -> Step:
        """A sample arrived at local time ``local``; ``raw``: anything the
        shell wants back with it when it is captured (its serialized
        form).  Returns a Step."""
        step = Step()
        if self.clock is None:
            self._reject('no_clock')
            return step
        arrival = self.clock.to_global(local)
        try:
            self.check(msg)
        except Rejected as e:
            self.invalid[e.reason] += 1
            self.last_invalid = str(e)[:200]
            self._reject(e.reason, arrival)
            return step
        if self.stamp_source == 'device':
            stamped = self._stamp_device(msg, raw, arrival, local)
        elif self.stamp_source == 'host':
            stamped = self._stamp_host(msg, raw, arrival, local)
        else:
            self.mapping.observe(arrival, arrival)
            stamped = [(arrival, msg, raw, arrival, local)]
        for sample in stamped:
            self._take(step, *sample)
        return step

    def refuse(self, reason: str) -> None:
        """Count a sample the shell could not even read (``reason``)."""
        self.counts[reason] += 1

    def _take(self, step: Step, stamp: GlobalTime, msg: Any,
              raw: bytes | None, arrival: GlobalTime,
              local: LocalTime) -> None:
        """One stamped sample: to the history and the open windows."""
        bound = self.clock_bound(local) + self.stamp_error(msg)
        self._lags.append(max(0.0, arrival - stamp))
        if self._last_stamp is not None:
            self._steps.append(stamp - self._last_stamp)
            if stamp > self._last_stamp:
                self._gaps.append(stamp - self._last_stamp)
        self._last_stamp = stamp
        if self.baseline is not None:
            self.baseline.add(stamp, msg)
        self.history.add(stamp, (msg, raw, arrival, bound))
        for round_id, start, end in self.closed:   # before this sample
            if start <= stamp < end:
                self.counts['late_after_result'] += 1
                step.late.append(round_id)
        captured, least = False, self.least_gap
        for w in list(self.windows.values()):
            took = w.offer(stamp, msg, arrival, bound, least)
            captured |= took and w.round != CALIBRATION_ROUND
            if w.complete:
                step.results.append(self._close(w))
        if captured:
            step.captured.append((stamp, msg, raw))

    def open(self, round_id: int, start: GlobalTime,
             end: GlobalTime) -> Step:
        """A capture command for [start, end) (global).  Returns a Step:
        the samples of the history already in the window, and an error
        result when the window cannot be captured.

        A second command of a round follows ``wire.rounds``: the same
        window is ignored ('duplicate_command'); another one is ignored
        while the round's window is open and captured once it is closed
        (the CPM orders once per round: the earlier one was not its
        own), both counted as 'conflicting_command'.
        """
        step = Step()
        repeat, take = self.rounds.take(round_id, (start, end),
                                        round_id in self.windows)
        if repeat:
            self.counts[repeat + '_command'] += 1
        if not take:
            return step
        why = None
        if self.clock is None:
            why = 'no clock_state from the CPM'
        elif not (math.isfinite(start) and math.isfinite(end)
                  and end > start):
            why = 'capture window [%r, %r) is empty or not finite' % (
                start, end)
        if why:
            step.results.append(self._error(round_id, start, end, why))
            return step
        w = CaptureWindow(round_id, start, end, self.make_processor(),
                          self.reorder, self.margin, self.max_period)
        self.windows[round_id] = w
        if round_id != CALIBRATION_ROUND:
            self._spans.append((start, end))
        least = self.least_gap
        for f in self.history.take(start, GlobalTime(math.inf)):
            msg, raw, arrival, bound = f.msg
            if w.offer(GlobalTime(f.stamp), msg, arrival, bound, least) and \
                    round_id != CALIBRATION_ROUND:
                step.captured.append((f.stamp, msg, raw))
            if w.complete:
                step.results.append(self._close(w))
                break
        return step

    def calibrate(self, start: GlobalTime, end: GlobalTime) -> Step:
        """The CM's calibration window [start, end) (global; nobody
        moves): captured as a window of round ``CALIBRATION_ROUND``, whose
        result (``WindowResult.calibration``), when ok, sets the quiet
        level of every later result's noise floor.  Its samples are not
        among a Step's ``captured``: the republished samples are the
        rounds'."""
        return self.open(CALIBRATION_ROUND, start, end)

    def started(self, round_id: int, local: LocalTime) -> None:
        """The shell's wake-up at the window start came at ``local``."""
        w = self.windows.get(round_id)
        if w is not None and self.clock is not None:
            w.wake_lateness = self.clock.to_global(local) - w.start

    def poll(self, local: LocalTime) -> list[Any]:
        """Results of windows complete at local time ``local`` for lack of
        samples."""
        if self.clock is None:
            return []
        now = self.clock.to_global(local)
        period, lag = self.period, self.lag
        return [self._close(w) for w in list(self.windows.values())
                if w.due(now, period, lag)]

    def next_poll(self) -> float | None:
        """The local time before which no open window can be due (None
        without open windows): a poll can sleep until then."""
        if self.clock is None or not self.windows:
            return None
        return min(self.clock.to_local(GlobalTime(w.end + self.margin))
                   for w in self.windows.values())

    # -- results ----------------------------------------------------------

    def _totals(self) -> dict[str, int | str]:
        c = self.counts
        return {'unstamped_total': c['no_clock'] + c['no_device_stamp']
                + c['bad_device_stamp'],
                'bad_device_stamps_total': c['bad_device_stamp'],
                'device_clock_resets': getattr(self.mapping, 'resets', 0),
                'device_clock_settling_total': c['settling'],
                'late_after_result_total': c['late_after_result'],
                'unreadable_total': c['unreadable'],
                'invalid_total': sum(self.invalid.values()),
                'stamp_source': self.stamp_source}

    def _error(self, round_id: int, start: GlobalTime, end: GlobalTime,
               why: str) -> WindowResult:
        stats = window_stats([], start, end)
        return WindowResult(round_id, ERROR, start, end,
                            coverage=stats['coverage'],
                            diagnostics=dict(self._totals(), error=why))

    def _silence(self, end: float, period: float) -> str:
        """Why the sensor counts as silent at the window's ``end`` (global):
        no sample ever, or none for more than three periods before it;
        '' when it was delivering."""
        if self._last_stamp is None:
            return 'no sample from the sensor since this DPM started'
        gap = end - self._last_stamp
        if not math.isfinite(period):
            period = self.period
        if math.isfinite(period) and gap > 3 * period:
            return ('no sample from the sensor for the last %.3f s of the '
                    'window' % gap)
        return ''

    def _close(self, w: CaptureWindow) -> WindowResult:
        del self.windows[w.round]
        self.closed.append((w.round, w.start, w.end))
        status, res, stats, error = w.finish(self.min_coverage)
        residual = self.mapping.residual
        # A sample in the window was stamped at its arrival, at most
        # ``jump`` s before its stamp: the map's moves since then count.
        moves = [s for a, s in self._shifts if a >= w.start - self.jump]
        shift = sum(moves)
        clock = self.clock
        bound = residual + shift + (
            w.bound if len(w.stamps) or clock is None
            else self.clock_bound(clock.to_local(w.end)))
        diagnostics = dict(res.diagnostics) if res else {'error': error}
        diagnostics.update(self._totals())
        diagnostics.update({
            'completed_by': w.completed_by, 'late_samples': w.late,
            'period': stats['period'],
            'device_map_residual': residual,
            'device_map_shift': shift,
            'device_map_moves': len(moves),
            'unstamped': sum(w.rejected[k] for k in (
                'no_device_stamp', 'bad_device_stamp')),
            'bad_device_stamps': w.rejected['bad_device_stamp']})
        invalid = {r: w.rejected[r] for r in self.invalid if w.rejected[r]}
        for reason, n in invalid.items():
            diagnostics['invalid_' + reason] = n
        if invalid:
            diagnostics['invalid_example'] = self.last_invalid
        silent = self._silence(w.end, stats['period'])
        if silent:
            diagnostics['sensor_silent'] = silent
        value = res.value if res else math.nan
        floor, source = self._noise(w, status, value, res, diagnostics)
        return WindowResult(
            w.round, status, w.start, w.end,
            frames=res.frames_used if res else 0,
            frames_rejected=(res.frames_rejected if res else 0)
            + sum(invalid.values()),
            frames_dropped=stats['dropped'], coverage=stats['coverage'],
            first_frame_offset=stats['first_frame_offset'],
            wake_lateness=w.wake_lateness, value=value,
            timing_uncertainty=bound, noise_floor=floor,
            diagnostics=diagnostics, noise_source=source)

    def _noise(self, w: CaptureWindow, status: str, value: float, res: Any,
               diagnostics: dict) -> tuple[float, str]:
        """The window's (noise floor, NoiseSource), a calibration window
        taken first; how they were made goes into ``diagnostics``."""
        cal = self.calibration
        if w.round == CALIBRATION_ROUND and self.baseline is not None:
            # (a processor without a quiet level, whose value is not a
            # level of activity, calibrates nothing)
            cal.take(status == ResultStatus.OK, value, w.start, w.end,
                     diagnostics.get('error') or 'its status is %s%s' % (
                         status, ': ' + diagnostics['sensor_silent']
                         if 'sensor_silent' in diagnostics else ''))
        own = res.noise_floor if res else math.nan
        quiet, stretches = (self.baseline.level() if self.baseline
                            else (math.nan, 0))
        diagnostics.update({
            'noise_window': own, 'noise_quiet': quiet,
            'noise_quiet_stretches': stretches,
            'noise_quiet_in_window': bool(self.baseline
                                          and self.baseline.in_window()),
            'noise_calibration': cal.level,
            'noise_calibrated_at': cal.start})
        if cal.failed:
            diagnostics['noise_calibration_failed'] = cal.failed
        return cal.floor(own, quiet, self.baseline is not None)
