"""The calibration window (nobody moving): the CM's order, the DPM's
calibrated noise floor, the DM's answer and its noise rule's trust, the
simulated sensor standing still.  Fake clocks, seeded, no ROS."""
import math
from types import SimpleNamespace as NS

import numpy as np
import pytest

from hri_sync.clock.model import ClockModel
from hri_sync.control.calibration import CalibrationRun
from hri_sync.control.session import Log
from hri_sync.dance_off.skeleton_source import SkeletonSource
from hri_sync.data_process.dpm import DataProcess
from hri_sync.data_process.health import noise_health as dpm_noise_health
from hri_sync.data_process.noise_floor import Calibration
from hri_sync.data_process.processors import Processor, ProcessResult
from hri_sync.decision.health import noise_health as dm_noise_health
from hri_sync.decision.rule import (NO_WINNER, NOISE, WINNER, RoundCollector,
                                    calibration_verdict, decide)
from hri_sync.wire.health import OK, WARN
from hri_sync.wire.protocol import Capture, ProtocolError
from hri_sync.wire.vocabulary import CALIBRATION_ROUND, NoiseSource

CAL = NoiseSource.NOISE_CALIBRATION
UNCAL = NoiseSource.NOISE_UNCALIBRATED
OFFSET = 5.0            # global - local
RATE = 20.0


class Level(Processor):
    """The mean of the samples' ``value``: a level of activity, with a
    quiet baseline."""

    quiet_baseline = True

    def begin(self, start, end):
        self._v = []

    def add(self, frame):
        self._v.append(frame.msg.value)

    def result(self):
        return ProcessResult(float(np.mean(self._v)) if self._v else 0.0,
                             len(self._v))


def dpm():
    d = DataProcess(Level)
    d.set_clock(ClockModel(0.0, OFFSET, 0.0, 50e-6))
    return d


def feed(d, t0, t1, level):
    """Samples at RATE from local t0 to t1 of value ``level(global t)``;
    the results they complete."""
    out = []
    for k in range(int(round((t1 - t0) * RATE))):
        local = t0 + k / RATE
        out += d.on_sample(NS(value=level(local + OFFSET)), local).results
    return out


def dancing(t):
    """A dancer: 5, but a quieter second (2) from 12 to 13 s global."""
    return 2.0 if 12.0 <= t < 13.0 else 5.0


def test_without_calibration_the_floor_is_the_quietest_second_untrusted():
    d = dpm()
    d.open(1, 10.0, 15.0)               # the dancer's pause is in it
    (r,) = feed(d, 0.0, 11.0, dancing)
    assert (r.round, r.status, r.value) == (1, 'ok', pytest.approx(4.4))
    assert r.noise_floor == pytest.approx(2.0)
    assert r.noise_source == UNCAL and not r.calibration
    assert r.diagnostics['noise_quiet_in_window'] is True
    assert math.isnan(r.diagnostics['noise_calibration'])


def test_a_quiet_second_outside_the_windows_is_said_so():
    d = dpm()
    d.open(1, 14.0, 15.0)
    (r,) = feed(d, 0.0, 11.0, dancing)
    assert r.noise_floor == pytest.approx(2.0) and r.noise_source == UNCAL
    assert r.diagnostics['noise_quiet_in_window'] is False


def test_the_calibration_window_sets_the_floor_of_every_later_window():
    d = dpm()
    assert not d.calibrate(8.0, 10.0).results
    results = feed(d, 0.0, 5.2, lambda t: 0.3 if 8.0 <= t < 10.0
                   else dancing(t))
    (cal,) = results
    assert cal.calibration and cal.round == CALIBRATION_ROUND
    assert (cal.status, cal.value) == ('ok', pytest.approx(0.3))
    assert (cal.noise_floor, cal.noise_source) == (pytest.approx(0.3), CAL)
    assert d.calibration.done and d.calibration.start == 8.0
    d.open(1, 11.0, 14.0)
    (r,) = feed(d, 5.2, 9.2, dancing)
    assert (r.noise_floor, r.noise_source) == (pytest.approx(0.3), CAL)
    assert r.diagnostics['noise_calibration'] == pytest.approx(0.3)
    assert r.diagnostics['noise_calibrated_at'] == 8.0
    # quieter than the calibration later on: the calibration still holds
    d.open(2, 15.0, 17.0)
    (r,) = feed(d, 9.2, 12.2, lambda t: 0.1)
    assert r.noise_floor == pytest.approx(0.3)
    assert r.diagnostics['noise_quiet'] == pytest.approx(0.1)


def test_a_calibration_without_data_says_why_and_calibrates_nothing():
    d = dpm()
    d.calibrate(8.0, 10.0)
    feed(d, 0.0, 2.0, dancing)          # the sensor stops at 7 s global
    (cal,) = d.poll(6.0)                # local: 11 s global
    assert cal.calibration and cal.status == 'no_data'
    assert not d.calibration.done
    assert 'no sample' in cal.diagnostics['noise_calibration_failed']
    d.open(1, 12.0, 13.0)
    (r,) = feed(d, 6.5, 8.5, dancing)
    assert r.noise_source == UNCAL
    assert 'no sample' in r.diagnostics['noise_calibration_failed']


def test_calibration_keeps_an_earlier_one_when_the_next_fails():
    c = Calibration()
    assert c.floor(0.1, 2.0, True) == (2.0, UNCAL)
    assert c.floor(0.1, math.nan, False) == (0.1,
                                             NoiseSource.NOISE_ESTIMATE)
    assert math.isnan(c.floor(math.nan, math.nan, True)[0])
    assert c.floor(math.nan, math.nan, True)[1] == ''
    c.take(True, 0.3, 8.0, 10.0)
    c.take(False, 0.0, 20.0, 22.0, 'its status is partial')
    assert c.level == 0.3 and c.failed == 'its status is partial'
    assert c.floor(0.5, 2.0, True) == (0.5, CAL)   # its own estimate above
    c.take(True, -1.0, 30.0, 32.0)
    assert c.level == 0.3 and 'not a noise level' in c.failed


def test_noise_rule_does_not_trust_an_uncalibrated_floor():
    # The dancers' round: the follower's floor is its own quietest
    # dancing second.  Calibrated, the follower wins; not, the threshold
    # rule decides for it, and says so.
    P = ['left', 'right']
    dancers = {'left': ('ok', 27.3, 0.32, CAL),
               'right': ('ok', 62.4, 36.7, CAL)}
    v = decide(P, dancers, min_value=1.0, rule=NOISE)
    assert v.outcome == NO_WINNER and 'within noise' in v.reason
    v = decide(P, dict(dancers, right=('ok', 62.4, 36.7, UNCAL)),
               min_value=1.0, rule=NOISE)
    assert (v.outcome, v.winner) == (WINNER, 2)
    assert 'noise floor of right not calibrated: min_expressiveness rule' \
        in v.reason
    assert math.isnan(v.noise_floors[1]) and v.noise_floors[0] == 0.32
    v = decide(P, {'left': ('ok', 3.0, 0.3, CAL),
                   'right': ('ok', 0.3, 0.4, UNCAL)}, rule=NOISE)
    assert (v.outcome, v.winner) == (WINNER, 1)
    assert 'noise floor of right not calibrated: tie_margin rule' in v.reason
    # '' (a recording made before noise_source): decided as it was
    v = decide(P, {'left': ('ok', 3.0, 0.3, ''),
                   'right': ('ok', 0.3, 0.3, '')}, rule=NOISE)
    assert v.noise_floors == [0.3, 0.3] and 'not calibrated' not in v.reason


def test_calibration_verdict_and_collector():
    P = ['left', 'right']
    v = calibration_verdict(P, {'left': ('ok', 0.32, 0.32, CAL),
                                'right': ('no_data', math.nan)})
    assert (v.outcome, v.winner) == (NO_WINNER, 0)
    assert v.scores[0] == 0.32 and math.isnan(v.scores[1])
    assert 'left still score 0.32, noise floor 0.32 (calibration)' in \
        v.reason and 'right not calibrated (no_data)' in v.reason
    c = RoundCollector(P, 2.0, rule=NOISE, calibration=True)
    assert c.open(CALIBRATION_ROUND, 10.0)
    c.add(CALIBRATION_ROUND, 'left', 'ok', 50.0, 1e-4, 0.3, CAL)
    closed, why = c.add(CALIBRATION_ROUND, 'right', 'ok', 0.3, 1e-4, 0.3,
                        CAL)
    assert why == '' and closed.verdict.outcome == NO_WINNER   # never wins
    assert c.add(CALIBRATION_ROUND, 'left', 'ok', 1.0)[1] == 'closed_round'


def test_collector_counts_and_remembers_the_floors_sources():
    c = RoundCollector(['left', 'right'], 2.0, rule=NOISE)
    c.open(1, 10.0)
    c.add(1, 'left', 'ok', 3.0, 1e-4, 0.3, CAL)
    closed, _ = c.add(1, 'right', 'ok', 0.2, 1e-4, 0.3, UNCAL)
    assert dict(c.noise_uncalibrated) == {'right': 1}
    assert c.noise_sources == {'left': CAL, 'right': UNCAL}
    assert 'right not calibrated' in closed.verdict.reason
    h = dm_noise_health(True, ['left', 'right'], c.noise_sources,
                        c.noise_unknown, c.noise_uncalibrated)
    assert h.level == WARN and 'right not calibrated' in h.message
    assert h.value('uncalibrated floors of right') == '1'
    assert dm_noise_health(False, ['left'], {'left': UNCAL}, {}, {}).level \
        == OK
    h = dm_noise_health(True, ['left', 'right'], {'left': CAL, 'right': ''},
                        {'right': 2}, {})
    assert h.level == OK and h.value('right') == 'none'


def test_dpm_noise_status():
    assert dpm_noise_health(True, 0.3, 8.0, '', 0.2).level == OK
    h = dpm_noise_health(True, math.nan, math.nan, 'its status is no_data',
                         36.7)
    assert h.level == WARN and 'no_data' in h.message and '36.7' in h.message
    assert dpm_noise_health(False, math.nan, math.nan, '', math.nan).level \
        == OK


def test_calibration_run_orders_one_window_and_waits_for_the_answer():
    run = CalibrationRun(['left', 'right'], 5.0, 1.0, 3.0)
    order, log = run.start(100.0)
    assert isinstance(order, Capture) and isinstance(log, Log)
    assert (order.round, order.start, order.end, order.clients) == \
        (CALIBRATION_ROUND, 101.0, 106.0, ['left', 'right'])
    assert 'stand still for 5.0 s' in log.text
    assert run.poll(106.5) == [] and not run.done
    assert run.on_decision(3)[0].level == 'debug'      # not its answer
    assert run.on_decision(CALIBRATION_ROUND) == []
    (done,) = run.poll(106.6)
    assert run.done and done.level == 'info'
    assert run.poll(107.0) == []


def test_calibration_run_goes_on_at_its_deadline():
    run = CalibrationRun(['left'], 2.0, 0.5, 3.0)
    run.start(10.0)
    assert run.poll(15.4) == []
    (late,) = run.poll(15.5)            # window end 12.5 + 3 s
    assert run.done and late.level == 'error'
    assert run.on_decision(CALIBRATION_ROUND)[0].level == 'debug'


@pytest.mark.parametrize('args', [([], 5.0, 1.0, 3.0), (['a'], 0.0, 1.0, 3.0),
                                  (['a'], 5.0, -1.0, 3.0),
                                  (['a'], math.nan, 1.0, 3.0),
                                  (['a'], 5.0, 1.0, 0.0)])
def test_calibration_run_refuses_bad_params(args):
    with pytest.raises(ProtocolError):
        CalibrationRun(*args)


class Ramp:
    """A Motion-like clip: every joint at x = clip time."""

    def positions_at(self, clip, mode):
        return np.repeat(np.asarray(clip)[:, None, None], 15, 1) * \
            np.array([1.0, 0.0, 0.0])

    def orientations_at(self, clip, mode):
        return np.zeros((len(clip), 15, 4))


def test_a_simulated_person_stands_still_in_the_calibration_and_goes_on():
    s = SkeletonSource(Ramp(), noise=0.0, seed=1)
    s.pause(10.0, 15.0)
    ticks = np.array([9.0, 10.0, 12.0, 14.99, 15.0, 16.0])
    assert s.clip_times(ticks, 0.0) == pytest.approx(
        [9.0, 10.0, 10.0, 10.0, 10.0, 11.0])
    x = s.frames(ticks, 0.0).positions[:, 0, 0]
    assert x == pytest.approx([9.0, 10.0, 10.0, 10.0, 10.0, 11.0])
    partner = SkeletonSource(Ramp(), noise=0.0, speed=1.0, offset=3.0)
    partner.pause(10.0, 15.0)           # paused alike: still together
    assert partner.clip_times(ticks, 0.0) - s.clip_times(ticks, 0.0) == \
        pytest.approx(np.full(6, 3.0))
    held = SkeletonSource(Ramp(), noise=0.0, hold=2.0)
    held.pause(10.0, 15.0)
    assert held.clip_times(ticks, 0.0) == pytest.approx(np.full(6, 2.0))


def test_a_clip_started_over_at_the_window_shows_its_beginning_there():
    s = SkeletonSource(Ramp(), noise=0.0, offset=2.0, seed=1)
    s.pause(10.0, 15.0)                 # the calibration, before the window
    s.pause(30.0, 31.0)                 # one after it still counts
    s.restart(20.0)
    ticks = np.array([20.0, 20.5, 30.5, 32.0])
    assert s.clip_times(ticks, 20.0) == pytest.approx([2.0, 2.5, 12.0, 13.0])
    s.restart(30.5)                     # a pause it cuts counts from there
    assert s.clip_times([30.5, 31.5], 30.5) == pytest.approx([2.0, 2.5])


def test_a_recording_files_the_calibration_apart_from_the_rounds():
    from hri_sync.tools import analysis
    from hri_sync.tools.bag import BagContents, Recorded
    from hri_sync.tools.session import build_session

    def stamp(t):
        return NS(sec=int(t), nanosec=int(round((t % 1) * 1e9)))

    def result(client, status, value, floor, source):
        return NS(header=NS(stamp=stamp(9.0)), round=0, client_id=client,
                  status=status, value=value, noise_floor=floor,
                  noise_source=source)
    c = BagContents('s.bag')
    msgs = {
        '/calibration/capture_data': ('hri_sync/CaptureData', [NS(
            header=NS(stamp=stamp(1.0)), round=0, str_aft=1.0, dur=5.0,
            clients=['left', 'right'])]),
        '/calibration/client_result': ('hri_sync/ClientResult', [
            result('left', 'ok', 0.32, 0.32, CAL),
            result('right', 'no_data', math.nan, math.nan, '')]),
        '/calibration/decision': ('hri_sync/Decision', [NS(
            header=NS(stamp=stamp(9.5)), round=0, outcome='no_winner',
            winner=0, reason='calibration window')]),
        '/decision': ('hri_sync/Decision', [NS(
            header=NS(stamp=stamp(20.0)), round=1, outcome='winner',
            winner=1, reason='left', clients=['left', 'right'])])}
    for topic, (kind, items) in msgs.items():
        c.topics[topic] = kind
        c.messages[topic] = [Recorded(k + 1.0, topic, m)
                             for k, m in enumerate(items)]
    s = build_session(c)
    assert sorted(s.rounds) == [1]
    assert (s.calibration.start, s.calibration.end) == (2.0, 7.0)
    assert sorted(s.calibration.results) == ['left', 'right']
    summary = analysis.calibration(s)
    assert summary['clients']['left']['noise_source'] == CAL
    assert summary['clients']['right']['noise_source'] is None
    text = analysis.calibration_text(summary)
    assert text.startswith('calibration: 5.0 s window; left ok, still '
                           'score 0.32, noise floor 0.32 (calibration); '
                           'right no_data')
    assert text.endswith('answer: no_winner')
    c.topics = {'/decision': 'hri_sync/Decision'}
    assert analysis.calibration(build_session(c)) is None
    assert 'none recorded' in analysis.calibration_text(None)


def test_calibration_text_of_a_client_with_no_still_score():
    # A client whose calibration result holds no value (NaN on the wire,
    # None in the summary) is printed as such, not a TypeError.
    from hri_sync.tools import analysis
    summary = {'dur_s': 5.0, 'outcome': 'no_winner', 'clients': {
        'left': {'status': 'partial', 'value': None, 'noise_floor': None,
                 'noise_source': None}}}
    assert analysis.calibration_text(summary) == (
        'calibration: 5.0 s window; left partial, still score n/a, noise '
        'floor n/a (n/a); answer: no_winner')


def test_a_processor_without_a_quiet_level_calibrates_nothing():
    # CountMean's value is a mean, not a level of activity: its floor
    # stays unknown and the decision module's threshold rule decides.
    from hri_sync.data_process.processors import CountMean
    d = DataProcess(CountMean)
    d.set_clock(ClockModel(0.0, OFFSET, 0.0, 50e-6))
    d.calibrate(8.0, 10.0)
    d.open(1, 11.0, 12.0)
    cal, r = feed(d, 0.0, 7.2, lambda t: 2.0)
    assert cal.calibration and cal.status == 'ok' and cal.value == 2.0
    assert not d.calibration.done
    assert math.isnan(r.noise_floor) and r.noise_source == ''
    assert math.isnan(cal.noise_floor) and cal.noise_source == ''


def test_the_calibration_windows_samples_are_not_republished():
    # <client>/captured holds the samples the rounds' results were
    # computed from, no more.
    d = dpm()
    d.calibrate(8.0, 10.0)
    d.open(1, 11.0, 12.0)
    steps = [d.on_sample(NS(value=0.3), k / RATE)
             for k in range(int(7.2 * RATE))]
    cal, r = [x for s in steps for x in s.results]
    captured = [c for s in steps for c in s.captured]
    assert cal.frames == 40 and r.frames == 20
    assert len(captured) == r.frames
    assert all(11.0 <= t < 12.0 for t, _, _ in captured)
    late = dpm()
    feed(late, 0.0, 4.0, dancing)       # history: 7 to 9 s global
    step = late.calibrate(8.0, 9.5)
    assert step.captured == [] and 8.0 in [w.start for w in
                                           late.windows.values()]


def test_the_calibration_window_on_a_sensors_own_clock():
    from hri_sync.control.calibration import host_window
    order = Capture(CALIBRATION_ROUND, 100.0, 1.0, 5.0, ['left'])
    own = ClockModel(0.0, 40.0, 0.0, 1e-4)      # global = local + 40
    # received 3 ms after its sending, by this host's clock model
    assert host_window(order, 60.003, own) == pytest.approx((60.8, 66.2))
    # a model of another clock (a CPM under libfaketime, 1.2 s off): the
    # window STR_AFT after the receipt
    faked = ClockModel(0.0, 41.2, 0.0, 1e-4)
    assert host_window(order, 60.003, faked) == pytest.approx((60.803,
                                                               66.203))
    assert host_window(order, 60.003, None, margin=0.0) == \
        pytest.approx((61.003, 66.003))


def test_calibration_window_before_the_recording():
    # A later part of a split recording holds the latched answer of the
    # calibration but not its window: said so, not a TypeError.
    from types import SimpleNamespace as NS
    from hri_sync.tools import analysis
    cal = NS(start=None, end=None, results={}, decision=NS(msg=NS(
        outcome='no_winner', reason='calibrated')))
    summary = analysis.calibration(NS(calibration=cal))
    assert summary['dur_s'] is None and summary['outcome'] == 'no_winner'
    cal.start = cal.end = math.nan      # NaN where its capture is missing
    assert analysis.calibration(NS(calibration=cal)) == summary
    assert analysis.calibration_text(summary) == (
        'calibration: window before this recording; no result recorded; '
        'answer: no_winner')
