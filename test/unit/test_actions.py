"""hri_sync.robot.actions: configured actions at round events, on a fake
clock."""
import math

import pytest

from hri_sync.robot.actions import (
    ACTIONLIB_TIMEOUT, COMMAND_TIMEOUT, SERVICE_TIMEOUT, ActionFailed,
    ActionScheduler, ActionTally, Begun, ConfigError, EndReport, Ending,
    Firing, StartReport, await_end, judge, judge_end, parse_action,
    parse_actions, run_firing)
from hri_sync.wire.health import ERROR, OK, WARN
from hri_sync.wire.vocabulary import Action, ActionEnd, Outcome

LIGHT = {'name': 'light', 'at': 'window_start', 'offset': -0.1,
         'publish': {'topic': '/light', 'type': 'std_msgs/Bool',
                     'fields': {'data': True}}}
MARK = {'name': 'mark', 'at': 'window_end',
        'service': {'service': '/logger/mark', 'type': 'std_srvs/Trigger'}}
WAVE = {'name': 'wave', 'at': 'decision', 'offset': 0.5,
        'outcomes': 'winner', 'winners': [1],
        'actionlib': {'server': '/arm', 'type': 'actionlib/TwoIntsAction',
                      'goal': {'a': 1, 'b': 2}}}
BEEP = {'name': 'beep', 'at': 'decision', 'outcomes': ['no_winner', 'tie'],
        'command': 'aplay "/tmp/a b.wav"', 'tolerance': 0.02}


class FakeClock:
    """Global time that moves only when waited on or told to."""

    def __init__(self, t=1000.0):
        self.t = t
        self.waits = []

    def now(self):
        return self.t

    def wait(self, target):
        self.waits.append(target)
        self.t = max(self.t, target)
        return max(0.0, self.t - target)


def test_each_kind_parses():
    light, mark, wave, beep = parse_actions([LIGHT, MARK, WAVE, BEEP])
    assert (light.kind, light.event, light.offset, light.target,
            light.type, light.fields) == (
        Action.PUBLISH, Action.WINDOW_START, -0.1, '/light',
        'std_msgs/Bool', {'data': True})
    assert (mark.kind, mark.target, mark.fields) == (
        Action.SERVICE, '/logger/mark', {})
    assert (wave.kind, wave.outcomes, wave.winners, wave.fields) == (
        Action.ACTIONLIB, (Outcome.WINNER,), (1,), {'a': 1, 'b': 2})
    assert beep.command == ('aplay', '/tmp/a b.wav')
    assert beep.tolerance == 0.02 and light.tolerance == 0.005
    assert parse_action(dict(BEEP, command=['ls', 3])).command == ('ls',
                                                                   '3')


@pytest.mark.parametrize('change, words', [
    ({'name': '9x'}, 'name='),
    ({'at': 'lunch'}, 'at='),
    ({'offset': math.nan}, 'offset='),
    ({'offset': 'soon'}, 'offset='),
    ({'tolerance': -1}, 'tolerance='),
    ({'max_late': -0.1}, 'max_late='),
    ({'colour': 'red'}, 'unknown keys'),
    ({'command': ['x']}, 'exactly one of'),
    ({'outcomes': 'winner'}, 'decisions only'),
    ({'publish': {'topic': '/x', 'type': 'Bool'}}, 'not a type'),
    ({'publish': {'topic': 'a b', 'type': 'std_msgs/Bool'}}, 'ROS name'),
    ({'publish': {'topic': '/x', 'type': 'std_msgs/Bool', 'qos': 1}},
     'unknown keys'),
    ({'publish': {'topic': '/x', 'type': 'std_msgs/Bool', 'fields': [1]}},
     'mapping of fields'),
    ({'publish': '/x'}, 'needs a mapping'),
])
def test_a_wrong_action_names_itself_and_the_key(change, words):
    with pytest.raises(ConfigError) as e:
        parse_action(dict(LIGHT, **change))
    assert words in str(e.value)
    assert str(e.value).startswith('action ') or 'name=' in str(e.value)


@pytest.mark.parametrize('change, words', [
    ({'command': ''}, 'non-empty list'),
    ({'command': 'a "b'}, 'No closing quotation'),
    ({'command': [True]}, 'non-empty list'),
    ({'outcomes': ['won']}, 'not among'),
    ({'winners': [-1]}, 'participant numbers'),
    ({'winners': ['a']}, 'participant numbers'),
])
def test_a_wrong_command_or_filter_is_refused(change, words):
    with pytest.raises(ConfigError, match=words):
        parse_action(dict(BEEP, **change))


def test_actionlib_needs_an_action_type():
    with pytest.raises(ConfigError, match='action type'):
        parse_action(dict(WAVE, actionlib=dict(WAVE['actionlib'],
                                               type='actionlib/TwoInts')))


def test_the_list_is_checked_whole():
    with pytest.raises(ConfigError, match='non-empty list'):
        parse_actions([])
    with pytest.raises(ConfigError, match='non-empty list'):
        parse_actions({'name': 'x'})
    with pytest.raises(ConfigError, match='used twice: light'):
        parse_actions([LIGHT, dict(MARK, name='light')])


def scheduler():
    logs = []
    return ActionScheduler(parse_actions([LIGHT, MARK, WAVE, BEEP]),
                           lambda level, text: logs.append((level, text))
                           ), logs


def test_window_events_fire_at_start_and_end_plus_offset():
    s, logs = scheduler()
    firings = s.on_capture(7, 1010.0, 1015.0)
    assert [(f.action.name, f.round, f.scheduled) for f in firings] == [
        ('light', 7, pytest.approx(1009.9)), ('mark', 7, 1015.0)]
    assert s.on_capture(7, 1010.0, 1015.0) == []
    assert logs == [('warn', 'round 7: a second window ignored')]


def test_decisions_filter_by_outcome_and_winner():
    s, _ = scheduler()
    assert [f.action.name for f in s.on_decision(
        1, Outcome.WINNER, 1, 1020.0, 1020.02)] == ['wave']
    assert s.on_decision(2, Outcome.WINNER, 2, 1030.0, 1030.02) == []
    assert [f.action.name for f in s.on_decision(
        3, Outcome.TIE, 0, 1040.0, 1040.02)] == ['beep']
    assert s.on_decision(4, Outcome.ABORTED, 0, 1050.0, 1050.02) == []
    (wave,) = s.on_decision(5, Outcome.WINNER, 1, 1060.0, 1060.02)
    assert wave.scheduled == 1060.5 and wave.note == ''
    assert s.on_decision(5, Outcome.WINNER, 1, 1060.0, 1060.02) == []


def test_a_decision_without_a_stamp_is_timed_from_its_receipt():
    s, _ = scheduler()
    (wave,) = s.on_decision(1, Outcome.WINNER, 1, 0.0, 1020.25)
    assert wave.scheduled == 1020.75 and 'no stamp' in wave.note


def test_a_late_order_still_fires_and_says_why():
    s, _ = scheduler()
    firings = s.on_late(3, 1010.0, 1015.0, 'order 20 ms after the start')
    assert [f.action.name for f in firings] == ['light', 'mark']
    assert all('capture order came late: order 20 ms' in f.note
               for f in firings)


def test_run_firing_waits_on_the_clock_and_reports_ok():
    clock = FakeClock(1000.0)
    (light,) = parse_actions([LIGHT])
    ran = []
    report = run_firing(Firing(light, 4, 1009.9), clock.now, clock.wait,
                        lambda a: ran.append(a) or Begun(),
                        lambda: (55.0, 1009.9))
    assert clock.waits == [1009.9] and ran == [light]
    assert (report.actual, report.local, report.true, report.status,
            report.reason, report.offset) == (
        1009.9, 55.0, 1009.9, Action.OK, '', 0.0)


def test_a_start_past_the_tolerance_is_late_with_its_reason():
    clock = FakeClock(1000.0)
    (light,) = parse_actions([LIGHT])

    def slow_wait(target):          # the thread woke 12 ms late
        clock.t = target + 0.012
        return 0.012
    report = run_firing(Firing(light, 4, 1001.0), clock.now, slow_wait,
                        lambda a: Begun(), lambda: (0.0, 0.0))
    assert report.status == Action.LATE
    assert report.offset == pytest.approx(0.012)
    assert '12.00 ms after' in report.reason and '5.00 ms' in report.reason


def test_a_failed_action_reports_why():
    clock = FakeClock(1000.0)
    (mark,) = parse_actions([MARK])

    def missing(action):
        raise ActionFailed('service /logger/mark is not available')
    report = run_firing(Firing(mark, 1, 1002.0), clock.now, clock.wait,
                        missing, lambda: (0.0, 0.0))
    assert (report.status, report.reason) == (
        Action.FAILED, 'service /logger/mark is not available')


def test_max_late_skips_a_firing_far_past_its_time():
    clock = FakeClock(1003.0)
    (beep,) = parse_actions([dict(BEEP, max_late=0.5)])
    ran = []

    def run(action):
        ran.append(action)
        return Begun()
    report = run_firing(Firing(beep, 1, 1002.0, 'because'), clock.now,
                        clock.wait, run, lambda: (0.0, 0.0))
    assert ran == [] and clock.waits == []
    assert report.status == Action.FAILED
    assert 'not run: 1000.0 ms after' in report.reason
    assert report.reason.endswith('; because')
    # Within max_late it runs, late.
    clock = FakeClock(1002.2)
    report = run_firing(Firing(beep, 1, 1002.0), clock.now, clock.wait,
                        run, lambda: (0.0, 0.0))
    assert ran == [beep] and report.status == Action.LATE


def test_a_stop_before_the_start_reports_nothing():
    (light,) = parse_actions([LIGHT])
    assert run_firing(Firing(light, 1, 1010.0), lambda: 1000.0,
                      lambda t: None, lambda a: Begun(),
                      lambda: (0.0, 0.0)) is None


def test_judge_keeps_a_note_on_an_ok_start():
    (light,) = parse_actions([LIGHT])
    assert judge(Firing(light, 1, 10.0, 'note'), 10.001) == (Action.OK,
                                                              'note')
    assert judge(Firing(light, 1, 10.0), 11.0, ActionFailed())[0] == \
        Action.FAILED
    assert judge(Firing(light, 1, 10.0, 'a'), 10.1, note='b') == (
        Action.LATE, 'began 100.00 ms after its scheduled time (tolerance '
        '5.00 ms); a; b')


def test_the_shells_note_on_a_start_is_its_reason():
    clock = FakeClock(1000.0)
    (light,) = parse_actions([LIGHT])
    report = run_firing(Firing(light, 1, 1001.0), clock.now, clock.wait,
                        lambda a: Begun('no subscriber'),
                        lambda: (0.0, 0.0))
    assert (report.status, report.reason) == (Action.OK, 'no subscriber')


def test_the_tally_reports_the_last_firings():
    light, mark = parse_actions([LIGHT, MARK])
    tally = ActionTally()
    assert (tally.health().level, tally.health().message) == (
        OK, 'no action fired yet')

    def report(action, status, reason='', n=1):
        tally.record(StartReport(Firing(action, n, 10.0), 10.0002, 0.0,
                                 0.0, status, reason))
    report(light, Action.OK)
    report(mark, Action.LATE, 'began 9 ms after')
    h = tally.health()
    assert (h.level, h.message) == (WARN, 'last firing late: mark')
    report(light, Action.FAILED, 'no subscriber type', 2)
    h = tally.health()
    assert (h.level, h.message) == (ERROR, 'last firing failed: light')
    values = dict(h.values)
    assert (values['ok'], values['late'], values['failed']) == ('1', '1',
                                                                '1')
    assert values['light'] == 'failed in round 2 at +0.20 ms: no ' \
        'subscriber type'
    report(light, Action.OK, n=3)
    report(mark, Action.OK, n=3)
    assert tally.health().level == OK


def test_timeout_defaults_per_kind_and_its_own():
    light, mark, wave, beep = parse_actions([LIGHT, MARK, WAVE, BEEP])
    assert (light.timeout, mark.timeout, wave.timeout, beep.timeout) == (
        0.0, SERVICE_TIMEOUT, ACTIONLIB_TIMEOUT, COMMAND_TIMEOUT)
    assert parse_action(dict(MARK, timeout=1)).timeout == 1.0


@pytest.mark.parametrize('item, words', [
    (dict(MARK, timeout=0), 'timeout=0: > 0 s'),
    (dict(BEEP, timeout=-2.0), 'timeout=-2.0: > 0 s'),
    (dict(WAVE, timeout=math.inf), 'timeout=inf'),
    (dict(WAVE, timeout='1 s'), "timeout='1 s'"),
    (dict(LIGHT, timeout=1.0), 'a publish ends when it is sent'),
])
def test_a_wrong_timeout_is_refused(item, words):
    with pytest.raises(ConfigError, match='action %s: .*%s' % (
            item['name'], words)):
        parse_action(item)


class FakeEnding(Ending):
    """An Ending on the fake clock that ends ``end_after`` s after it is
    made (None: never); records its sleeps and what abort did."""

    def __init__(self, clock, end_after, error=None):
        super().__init__(clock.now, self.fake_sleep)
        self.clock, self.error_at_end = clock, error
        self.end_at = None if end_after is None else clock.t + end_after
        self.slept, self.aborted = [], 0

    def fake_sleep(self, seconds):
        self.slept.append(seconds)
        self.clock.t += seconds
        if self.end_at is not None and self.clock.t >= self.end_at:
            self.finish(self.error_at_end, 'note')

    def abort(self):
        self.aborted += 1
        return 'its process group killed'


def began(action, clock, ending, status=Action.OK):
    return StartReport(Firing(action, 3, clock.t), clock.t, 0.0, 0.0,
                       status, '', ending)


def test_an_end_within_the_timeout_is_ok_or_failed():
    clock = FakeClock(1000.0)
    (beep,) = parse_actions([dict(BEEP, timeout=2.0)])
    ending = FakeEnding(clock, 0.5)
    end = await_end(began(beep, clock, ending), clock.now)
    assert max(ending.slept) == pytest.approx(0.01)     # END_POLL
    assert sum(ending.slept) == pytest.approx(0.5, abs=0.011)
    assert ending.aborted == 0
    assert (end.status, end.reason, end.ended, end.duration) == (
        ActionEnd.OK, 'note', pytest.approx(1000.5, abs=0.011),
        pytest.approx(0.5, abs=0.011))
    ending = FakeEnding(clock, 1.25, 'exited with status 3')
    end = await_end(began(beep, clock, ending), clock.now)
    assert (end.status, end.reason) == (ActionEnd.FAILED,
                                        'exited with status 3')
    assert end.duration == pytest.approx(1.25, abs=0.011)


def test_no_end_within_the_timeout_is_aborted_and_says_so():
    clock = FakeClock(1000.0)
    (beep,) = parse_actions([dict(BEEP, timeout=2.0)])
    ending = FakeEnding(clock, None)
    start = began(beep, clock, ending)
    clock.t += 0.5                  # the shell reported the start first
    end = await_end(start, clock.now)
    assert sum(ending.slept) == pytest.approx(1.5) and ending.aborted == 1
    assert (end.status, end.ended, end.duration) == (
        ActionEnd.TIMEOUT, pytest.approx(1002.0), pytest.approx(2.0))
    assert end.reason == 'no end 2.00 s after its start (timeout 2 s): ' \
        'its process group killed'
    # An end after the timeout is too late to count.
    assert not ending.finish()
    assert ending.ended is None


def test_a_publish_ends_at_once_and_a_failed_start_never():
    clock = FakeClock(1000.0)
    light, mark = parse_actions([LIGHT, MARK])
    end = await_end(began(light, clock, None), clock.now)
    assert (end.status, end.reason, end.duration) == (ActionEnd.OK, '', 0.0)
    assert await_end(began(mark, clock, FakeEnding(clock, 0.1),
                           Action.FAILED), clock.now) is None


def test_a_real_ending_counts_its_first_end_only():
    clock = FakeClock(1000.0)
    ending = Ending(clock.now, clock.wait)
    assert not ending.wait(0.0)
    assert ending.finish('goal ended ABORTED')
    clock.t = 1001.0
    assert not ending.finish() and not ending.expire()
    assert ending.wait(0.0)
    assert (ending.ended, ending.error) == (1000.0, 'goal ended ABORTED')
    expired = Ending(clock.now)
    assert expired.expire() and not expired.finish()
    assert expired.abort() == ''


def test_judge_end():
    (mark,) = parse_actions([dict(MARK, timeout=1.0)])
    assert judge_end(mark, 0.2) == (ActionEnd.OK, '')
    assert judge_end(mark, 0.2, 'answered success=false: busy') == (
        ActionEnd.FAILED, 'answered success=false: busy')
    assert judge_end(mark, 1.0004, aborted='') == (
        ActionEnd.TIMEOUT, 'no end 1.00 s after its start (timeout 1 s)')


def test_the_tally_reports_the_last_ends():
    light, mark, beep = parse_actions([LIGHT, MARK, BEEP])
    tally = ActionTally()

    def end(action, status, reason='', n=1):
        start = StartReport(Firing(action, n, 10.0), 10.0, 0.0, 0.0,
                            Action.OK, '')
        tally.record(start)
        tally.record_end(EndReport(start, 10.5, status, reason))
    end(light, ActionEnd.OK)
    assert tally.health().level == OK
    end(mark, ActionEnd.TIMEOUT, 'no end 5.00 s after its start')
    end(beep, ActionEnd.FAILED, 'exited with status 1')
    h = tally.health()
    assert (h.level, h.message) == (
        ERROR, 'last end failed: beep; last end timeout: mark')
    values = dict(h.values)
    assert (values['ended_ok'], values['ended_failed'],
            values['ended_timeout']) == ('1', '1', '1')
    assert values['mark end'] == 'timeout in round 1 after 0.500 s: no ' \
        'end 5.00 s after its start'
    end(mark, ActionEnd.OK, n=2)
    end(beep, ActionEnd.OK, n=2)
    assert tally.health().level == OK
