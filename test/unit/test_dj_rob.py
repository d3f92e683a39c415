"""DJ Rob's job scheduler on a fake clock: decisions, preemption, late
joins, the odometry pose, and whole rounds run on the base model."""
import math

import pytest

from hri_sync.robot.choreography import check_limits, max_move_displacement
from hri_sync.robot.dj_rob import (DANCE, GESTURE, Config, DjRob, Job,
                                   float_list)
from hri_sync.robot.kobuki import (LED_BLACK, LED_GREEN, SOUND_CLEANINGEND,
                                   ZERO, KobukiBase, Limits)

BEARINGS = (math.radians(30.0), math.radians(-30.0))


class FakeClock:
    """A clock that moves only when told to."""

    def __init__(self, t=100.0):
        self.t = t

    def __call__(self):
        return self.t


class Log(list):
    """Collects (level, text)."""

    def __call__(self, level, text):
        self.append((level, text))

    def texts(self, level):
        return [t for lv, t in self if lv == level]


def make(t=100.0, **config):
    clock, log = FakeClock(t), Log()
    rob = DjRob(Config(BEARINGS, **config), clock, clock, log)
    return rob, clock, log


def run_to_end(rob, clock, run):
    """Tick ``run`` to its end as the node does; returns the ticks."""
    ticks = []
    clock.t = max(clock.t, run.start)
    while True:
        tick = run.tick()
        if tick is None:
            return ticks
        ticks.append(tick)
        clock.t = tick.next


# --- decisions ---------------------------------------------------------
def test_winner_decision_queues_a_gesture_after_the_window():
    rob, clock, log = make()
    rob.on_capture(1, 101.0, 106.0, 1.0)
    clock.t = 105.0                       # decided before the window end
    assert rob.on_decision(1, 'winner', 2, 'b scored highest') == 'gesture'
    dance, gesture = rob.jobs
    assert (dance.kind, dance.start, dance.end) == (DANCE, 101.0, 106.0)
    assert (gesture.kind, gesture.winner, gesture.start) == (GESTURE, 2,
                                                             106.0)
    rob.on_capture(2, 111.0, 116.0, 1.0)
    clock.t = 117.0                       # decided after it: from now
    assert rob.on_decision(2, 'winner', 1) == 'gesture'
    assert rob.jobs[-1].start == 117.0
    assert log.texts('error') == []


@pytest.mark.parametrize('round_id, outcome, winner, verdict, text', [
    (1, 'winner', 7, 'winner_out_of_range',
     'dj_rob: round 1: winner 7 out of range 1..2: ignored'),
    (1, 'winner', 0, 'winner_out_of_range', 'winner 0 out of range 1..2'),
    (1001, 'winner', 1, 'unknown_round',
     'dj_rob: decision for round 1001 ignored: not a round this robot was '
     'scheduled in (known: [1])'),
    (1, 'bogus', 1, 'unknown_outcome',
     "dj_rob: round 1: unknown decision outcome 'bogus' ignored"),
])
def test_bad_decisions_are_logged_as_errors_and_ignored(
        round_id, outcome, winner, verdict, text):
    rob, clock, log = make()
    rob.on_capture(1, 101.0, 106.0, 1.0)
    jobs = list(rob.jobs)
    assert rob.on_decision(round_id, outcome, winner) == verdict
    assert rob.jobs == jobs               # nothing queued
    [error] = log.texts('error')
    assert text in error
    # the bad decision did not use up the round: a good one still counts
    assert rob.on_decision(1, 'winner', 1) == 'gesture'


def test_decision_before_any_round_names_none_known():
    rob, clock, log = make()
    assert rob.on_decision(3, 'winner', 1) == 'unknown_round'
    assert '(known: none)' in log.texts('error')[0]


def test_second_decision_for_a_round_is_ignored():
    rob, clock, log = make()
    rob.on_capture(1, 101.0, 106.0, 1.0)
    assert rob.on_decision(1, 'no_winner', 0) == 'no_gesture'
    assert rob.on_decision(1, 'winner', 1) == 'duplicate'
    assert log.texts('error') == [
        'dj_rob: second decision for round 1 ignored']
    assert [j.kind for j in rob.jobs] == [DANCE]


@pytest.mark.parametrize('outcome', ['no_winner', 'tie', 'aborted'])
def test_no_gesture_without_a_winner(outcome):
    rob, clock, log = make()
    rob.on_capture(1, 101.0, 106.0, 1.0)
    assert rob.on_decision(1, outcome, 0, 'why') == 'no_gesture'
    assert [j.kind for j in rob.jobs] == [DANCE]
    assert log.texts('error') == []
    assert 'round 1: %s (why): no gesture' % outcome in log.texts('info')[-1]


def test_a_late_round_is_known_and_its_winner_gestures():
    rob, clock, log = make()
    rob.on_late(4, 110.0, 'arrived 3 ms late')
    assert 'round 4: no dance (arrived 3 ms late)' in log.texts('error')[0]
    assert rob.jobs == []
    assert rob.on_decision(4, 'winner', 1) == 'gesture'


def test_winner_of_a_superseded_round_gets_no_gesture():
    rob, clock, log = make()
    rob.on_capture(1, 101.0, 106.0, 1.0)
    rob.on_sync_time(2)
    assert rob.on_decision(1, 'winner', 1) == 'superseded'
    assert [j.kind for j in rob.jobs] == [DANCE]
    assert 'round 2 has started: no gesture' in log.texts('warn')[0]


# --- preemption --------------------------------------------------------
def gesture_running(rob, clock, at=0.8):
    """Round 1 decided for participant 1; its gesture running at ``at`` s
    into its turn.  Returns the run."""
    rob.on_late(1, clock.t, 'test')
    rob.on_decision(1, 'winner', 1)
    job = rob.take()
    assert job.kind == GESTURE
    run = rob.begin(job)
    clock.t = run.start
    while clock.t < run.start + at:
        tick = run.tick()
        clock.t = tick.next
    assert tick.twist != ZERO             # it is moving
    return run, tick.twist


def test_new_round_cuts_a_running_gesture_short_at_the_limits():
    rob, clock, log = make()
    run, moving = gesture_running(rob, clock)
    rob.on_sync_time(2)
    assert rob.running.yield_now
    assert ('dj_rob: round 2 is starting: the winner gesture of round 1 is '
            'cut short (braking)') in log.texts('warn')
    ticks = run_to_end(rob, clock, run)
    lim = Limits()
    brake = max(abs(moving.angular) / lim.angular_accel,
                abs(moving.linear) / lim.linear_accel)
    assert ticks[0].twist == moving       # braking starts from there
    assert ticks[-1].now - ticks[0].now == pytest.approx(brake, abs=0.021)
    for a, b in zip(ticks, ticks[1:]):
        dt = b.now - a.now
        assert abs(b.twist.angular) <= abs(a.twist.angular)
        assert abs(b.twist.angular - a.twist.angular) <= \
            lim.angular_accel * dt + 1e-9
        assert b.events == []             # no LED green or sound now
    # LEDs off at the end; no turn counted as done
    assert [(e.kind, e.value) for e in run.finish()] == [
        ('led1', LED_BLACK), ('led2', LED_BLACK)]
    assert rob.dead_heading == 0.0


def test_new_round_drops_a_queued_gesture_but_not_a_dance():
    rob, clock, log = make()
    rob.on_capture(1, 101.0, 106.0, 1.0)
    rob.on_decision(1, 'winner', 2)
    rob.on_capture(2, 111.0, 116.0, 1.0)    # queued: dance, gesture, dance
    rob.on_sync_time(3)
    assert [(j.kind, j.round) for j in rob.jobs] == [(DANCE, 1), (DANCE, 2)]
    assert log.texts('warn') == [
        'dj_rob: round 3 is starting: the winner gesture of round 1 is '
        'dropped']


def test_a_queued_dance_makes_a_running_gesture_brake():
    rob, clock, log = make()
    run, moving = gesture_running(rob, clock)
    rob.on_capture(2, clock.t + 2.0, clock.t + 7.0, 2.0)   # no sync_time
    ticks = run_to_end(rob, clock, run)
    assert ticks[-1].now - ticks[0].now < 1.5     # not the whole gesture
    assert run.braking


def test_a_running_dance_does_not_yield():
    rob, clock, log = make()
    rob.on_capture(1, 101.0, 106.0, 1.0)
    run = rob.begin(rob.take())
    clock.t = 102.0
    rob.on_sync_time(2)
    assert not rob.running.yield_now
    assert log.texts('warn') == []
    ticks = run_to_end(rob, clock, run)
    assert not run.braking
    assert 105.97 < ticks[-1].now < 106.0


# --- dances on the beat --------------------------------------------------
def test_dance_on_time_starts_at_the_window_start():
    rob, clock, log = make()
    rob.on_capture(1, 101.0, 106.0, 1.0)
    job = rob.take()
    rob.on_odom(0.0, 0.0, 0.0)
    run = rob.begin(job)
    assert run.start == job.scheduled == 101.0
    ticks = run_to_end(rob, clock, run)
    assert ticks[0].now == 101.0 and ticks[0].first
    assert not any(t.first for t in ticks[1:])
    assert all(t.bobble is not None for t in ticks)
    assert [t.next for t in ticks[:3]] == pytest.approx([101.02, 101.04,
                                                         101.06])
    assert log.texts('error') == []


@pytest.mark.parametrize('late, beats', [
    (0.021, 1), (0.3, 1), (0.449, 1), (0.46, 2), (1.2, 3)])
def test_busy_base_joins_the_dance_on_a_later_beat(late, beats):
    rob, clock, log = make(beat=0.5)
    rob.on_capture(1, 101.0, 106.0, 1.0)
    job = rob.take()
    clock.t = 101.0 + late                 # the base was busy until now
    rob.on_odom(0.0, 0.0, 0.0)
    run = rob.begin(job)
    assert run.start == pytest.approx(101.0 + beats * 0.5)
    assert job.scheduled == 101.0
    [error] = log.texts('error')
    assert ('the base was busy until %.0f ms after the window start: the '
            'dance joins %.2f s late, on the beat' % (late * 1e3, beats * 0.5)
            in error)
    # its moves stay on the window's beat grid, and end by the window end
    assert run.motion.duration == pytest.approx(106.0 - run.start)
    for m in run.motion.moves:
        on_grid = (run.start - 101.0 + m.start) / 0.5
        assert on_grid == pytest.approx(round(on_grid), abs=1e-9)
        assert run.start + m.end <= 106.0 + 1e-9


def test_within_one_tick_is_on_time():
    rob, clock, log = make(period=0.02)
    rob.on_capture(1, 101.0, 106.0, 1.0)
    job = rob.take()
    clock.t = 101.019
    rob.on_odom(0.0, 0.0, 0.0)
    assert rob.begin(job).start == 101.0
    assert log.texts('error') == []


def test_dance_skipped_when_the_base_is_busy_until_the_window_end():
    rob, clock, log = make()
    rob.on_capture(1, 101.0, 102.0, 1.0)
    job = rob.take()
    clock.t = 101.7
    assert rob.begin(job) is None
    assert log.texts('error') == ['dj_rob: round 1: dance skipped: the base '
                                  'was busy until the window end']


# --- the pose ------------------------------------------------------------
def test_pose_is_relative_to_the_first_odometry():
    rob, clock, log = make()
    assert not rob.has_odom
    rob.on_odom(1.0, 2.0, math.pi / 2)
    assert rob.has_odom
    assert 'start pose from /odom: (1.000, 2.000) m, 90.0 deg' in \
        log.texts('info')[0]
    rob.on_odom(1.0, 3.0, math.pi / 2 + 0.25)       # 1 m ahead, turned
    x, y, heading, source = rob.pose()
    assert (x, y, heading) == pytest.approx((1.0, 0.0, 0.25))
    assert source == 'odometry'
    rob.on_odom(0.0, 2.0, -math.pi)                  # 1 m to the left
    assert rob.pose()[:3] == pytest.approx((0.0, 1.0, math.pi / 2))


def test_non_finite_odometry_is_refused():
    rob, clock, log = make()
    rob.on_odom(0.0, 0.0, 0.0)
    with pytest.raises(ValueError):
        rob.on_odom(math.nan, 0.0, 0.0)
    with pytest.raises(ValueError):
        rob.on_odom(0.0, 0.0, math.inf)
    assert rob.pose()[:3] == (0.0, 0.0, 0.0)


def test_stale_or_missing_odometry_falls_back_to_dead_reckoning():
    rob, clock, log = make()
    assert rob.pose() == (0.0, 0.0, 0.0, 'dead reckoning')
    assert 'no fresh /odom (never received)' in log.texts('error')[0]
    rob.on_odom(0.0, 0.0, 0.3)
    clock.t += 1.0
    assert rob.pose().source == 'odometry'
    clock.t += 0.5
    rob.dead_heading = 7.0
    x, y, heading, source = rob.pose()
    assert (x, y, source) == (0.0, 0.0, 'dead reckoning')
    assert heading == pytest.approx(7.0 - 2 * math.pi)
    assert 'no fresh /odom (last 1.5 s ago)' in log.texts('error')[-1]


def test_gesture_without_odometry_turns_by_dead_reckoning():
    rob, clock, log = make(distance=None)
    for n in (1, 2):
        rob.on_late(n, clock.t, 'test')
        rob.on_decision(n, 'winner', n)
        run = rob.begin(rob.take())
        ticks = run_to_end(rob, clock, run)
        events = [e for t in ticks for e in t.events] + run.finish()
        rob.done()
        assert rob.dead_heading == pytest.approx(BEARINGS[n - 1])
        assert [e.value for e in events if e.kind == 'sound'] == [
            SOUND_CLEANINGEND]
        assert [e.value for e in events if e.kind == 'led1'] == [
            LED_GREEN, LED_BLACK]
    assert 'turning from 30.0 to -30.0 deg (dead reckoning)' in \
        log.texts('info')[-1]


# --- whole rounds on the base model --------------------------------------
class Sim:
    """The node's runner on a fake clock, driving a KobukiBase whose pose
    goes back as odometry every 20 ms, with inputs at given times."""

    def __init__(self, rob, clock):
        self.rob, self.clock = rob, clock
        self.base = KobukiBase(start=clock.t)
        self.inputs = []
        self.next_odom = clock.t
        self.ticks = []             # (job kind, round, tick)
        self.stalls = []            # (from, to): the runner starved

    def at(self, t, action):
        self.inputs.append((t, action))
        self.inputs.sort(key=lambda i: i[0])

    def advance(self, t):
        while True:
            due = min([self.next_odom] + [i[0] for i in self.inputs[:1]])
            if due > t:
                break
            self.clock.t = max(self.clock.t, due)
            if self.inputs and self.inputs[0][0] <= due:
                self.inputs.pop(0)[1]()
            else:
                s = self.base.step(due)
                self.rob.on_odom(s.x, s.y, s.theta)
                self.next_odom += 0.02
        self.clock.t = max(self.clock.t, t)
        self.base.step(self.clock.t)

    def command(self, twist):
        self.base.step(self.clock.t)
        self.base.command(twist.linear, twist.angular, self.clock.t)

    def run(self, until):
        rob = self.rob
        while self.clock.t < until:
            job = rob.take()
            if job is None:
                self.advance(self.clock.t + 0.01)
                continue
            run = rob.begin(job)
            if run is not None:
                self.advance(run.start)
                while True:
                    stall = [e for b, e in self.stalls
                             if b <= self.clock.t < e]
                    if stall:           # no tick: the base keeps its last
                        self.advance(stall[0])      # command, then times out
                        continue
                    tick = run.tick()
                    if tick is None:
                        break
                    self.command(tick.twist)
                    self.ticks.append((job.kind, job.round, tick))
                    self.advance(tick.next)
                self.command(ZERO)
                run.finish()
            rob.done()


def test_a_round_ends_facing_the_winner_within_the_limits():
    rob, clock, log = make(t=0.0)
    sim = Sim(rob, clock)
    sim.at(0.5, lambda: rob.on_capture(1, 1.0, 6.0, 0.5))
    sim.at(6.3, lambda: rob.on_decision(1, 'winner', 2))
    sim.run(16.0)
    dance = [t for k, _, t in sim.ticks if k == DANCE]
    assert dance[0].now == 1.0 and dance[-1].now < 6.0
    s = sim.base.state
    assert math.degrees(s.theta) == pytest.approx(-30.0, abs=1.0)
    assert math.hypot(s.x, s.y) < 0.01
    assert sim.base.health().ok and sim.base.timeouts == 0
    assert log.texts('error') == [] and log.texts('warn') == []


@pytest.mark.parametrize('stall', [(6.6, 7.4), (6.9, 8.0)])
def test_a_starved_turn_is_turned_again_on_odometry(stall):
    # the runner stalls in the turn to the winner: its command times out
    # and the base stops short; the check after the turn turns it again
    rob, clock, log = make(t=0.0)
    sim = Sim(rob, clock)
    sim.stalls.append(stall)
    sim.at(0.5, lambda: rob.on_capture(1, 1.0, 6.0, 0.5))
    sim.at(6.3, lambda: rob.on_decision(1, 'winner', 2))
    sim.run(18.0)
    s = sim.base.state
    assert math.degrees(s.theta) == pytest.approx(-30.0, abs=2.0)
    assert math.hypot(s.x, s.y) < 0.01
    [again] = log.texts('warn')
    assert 'round 1: the turn to the winner ended at' in again
    assert 'turning again' in again
    assert sim.base.timeouts == 1


def test_a_turn_with_no_fresh_odometry_is_not_checked():
    rob, clock, log = make(distance=None)
    rob.on_late(1, clock.t, 'test')
    rob.on_decision(1, 'winner', 2)
    run = rob.begin(rob.take())
    run_to_end(rob, clock, run)
    run.finish()
    assert rob.dead_heading == pytest.approx(BEARINGS[1])
    assert log.texts('warn') == []


def dance_with_stalls(*stalls):
    """A dance over 1..6 s (forward, back, turn to participant 1 over
    3..4.5 s, turn to centre over 4.5..6 s) with the runner starved."""
    rob, clock, log = make(t=0.0)
    sim = Sim(rob, clock)
    sim.stalls.extend(stalls)
    sim.at(0.5, lambda: rob.on_capture(1, 1.0, 6.0, 0.5))
    sim.run(6.5)
    return rob, sim, log


def test_a_dance_turn_takes_up_an_earlier_turns_error():
    # starved in the first turn: without the re-aim it ends 1.8 deg off
    rob, sim, log = dance_with_stalls((3.0, 3.3))
    assert math.degrees(sim.base.state.theta) == pytest.approx(0.0, abs=0.1)
    [reaim] = log.texts('warn')
    assert "1.8 deg off the dance's heading (odometry) as its turn to " \
        'centre begins: turning -28.2 deg, not -30.0' in reaim
    lim = rob.config.limits
    assert check_limits([(t.now, t.twist) for _, _, t in sim.ticks],
                        lim) == []


def test_a_dance_turn_takes_up_no_more_than_the_limits_allow():
    rob, clock, log = make(t=0.0)
    rob.on_odom(0.0, 0.0, 0.0)
    rob.on_capture(1, 1.0, 6.0, 0.5)
    run = rob.begin(rob.take())
    clock.t = 3.0                       # the first turn, on its heading
    run.tick()
    clock.t = 4.5                       # the base is 70 deg past it
    rob.on_odom(0.0, 0.0, math.radians(100.0))
    run.tick()
    c = rob.config
    lim = c.limits.scaled(c.margin)
    most = max_move_displacement(1.5, lim.angular, lim.angular_accel)
    assert [m.angle for m in run.motion.moves[2:]] == pytest.approx(
        [math.radians(30.0), -most])
    [reaim] = log.texts('warn')
    assert '-70.0 deg off' in reaim
    assert 'turning %.1f deg, not -30.0' % -math.degrees(most) in reaim


def test_a_dance_turn_begun_late_is_not_reaimed():
    # the runner starved over the turn's start: its first tick comes
    # mid-turn, where a new angle would jump the velocity
    rob, clock, log = make(t=0.0)
    rob.on_odom(0.0, 0.0, 0.0)
    rob.on_capture(1, 1.0, 6.0, 0.5)
    run = rob.begin(rob.take())
    clock.t = 3.3
    rob.on_odom(0.0, 0.0, math.radians(-10.0))
    run.tick()
    assert run.motion == run.planned and log.texts('warn') == []


def test_the_last_turns_own_error_is_left_to_the_next_plan():
    # a short stall in the last turn: no turn is left to take it up
    rob, sim, log = dance_with_stalls((5.2, 5.5))
    assert math.degrees(sim.base.state.theta) == pytest.approx(-0.68,
                                                               abs=0.05)
    assert log.texts('warn') == [] and log.texts('error') == []


def test_next_round_cuts_the_gesture_short_and_dances_on_the_beat():
    rob, clock, log = make(t=0.0)
    sim = Sim(rob, clock)
    sim.at(0.5, lambda: rob.on_capture(1, 1.0, 6.0, 0.5))
    sim.at(6.3, lambda: rob.on_decision(1, 'winner', 1))
    # round 2 begins while the winner gesture turns: its window starts
    # before the base can have braked to rest
    sim.at(7.0, lambda: rob.on_sync_time(2))
    sim.at(7.01, lambda: rob.on_capture(2, 7.05, 12.05, 0.04))
    sim.run(14.0)
    gesture = [t for k, _, t in sim.ticks if k == GESTURE]
    dance2 = [t for k, n, t in sim.ticks if k == DANCE and n == 2]
    assert gesture[-1].now < dance2[0].now
    assert 'round 1 is cut short (braking)' in log.texts('warn')[0]
    [late] = log.texts('error')
    assert 'round 2: the base was busy until' in late
    # joined on a beat of round 2's window, after the brake
    k = (dance2[0].now - 7.05) / 0.5
    assert k >= 1 and k == pytest.approx(round(k), abs=1e-9)
    assert dance2[0].first
    # the brake kept to the limits: the base never clamped or slewed
    assert sim.base.health().ok and sim.base.timeouts == 0
    assert not [e for k, _, t in sim.ticks if k == GESTURE
                for e in t.events if e.kind == 'led1']


def test_float_list():
    assert float_list('[30.0, -30.0]') == [30.0, -30.0]
    assert float_list([1, '2']) == [1.0, 2.0]
    for bad in ('', [], ['nan'], 'a,b'):
        with pytest.raises(ValueError):
            float_list(bad)


def test_config_is_checked():
    with pytest.raises(ValueError):
        DjRob(Config(()), FakeClock(), FakeClock(), Log())
    with pytest.raises(ValueError):
        DjRob(Config(BEARINGS, margin=1.5), FakeClock(), FakeClock(), Log())


def test_jobs_run_in_start_order():
    rob, clock, log = make()
    rob.on_capture(2, 120.0, 125.0, 20.0)
    rob.on_capture(1, 110.0, 115.0, 10.0)
    assert [j.round for j in rob.jobs] == [1, 2]
    assert isinstance(rob.take(), Job) and rob.running.round == 1
    rob.done()
    assert rob.running is None
