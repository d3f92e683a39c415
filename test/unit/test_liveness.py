"""The CPM's liveness rule (its DPM alive, its sensor delivering) on a
fake clock, and how it turns an ACK into a NACK."""
import math

import pytest

from hri_sync.clock.model import ClockModel
from hri_sync.clock.sync import ClockStatus
from hri_sync.client_process.liveness import (Beat, Liveness, SampleMeter,
                                              Verdict)
from hri_sync.client_process.schedule import ClientSchedule

MODEL = ClockModel(local_ref=95.0, offset=2.0, uncertainty=0.001,
                   drift_bound=1e-4)
FRESH = ClockStatus(MODEL, '', 3)


def beat(received, age=0.05, samples=100, rate=20.0):
    return Beat(received, '/left/skeleton', samples, age, rate)


def rule(started=0.0):
    return Liveness(dpm_timeout=2.0, sensor_timeout=1.0, started=started)


def test_no_heartbeat_yet_is_dpm_not_alive():
    v = rule(started=10.0).verdict(13.5)
    assert not v.ok
    assert v.reason.startswith('dpm not alive')
    assert '3.5 s since this CPM started' in v.reason


def test_fresh_heartbeat_and_fresh_sample_is_alive():
    live = rule()
    live.on_beat(beat(100.0))
    assert live.verdict(100.5) == Verdict(True)


def test_a_dpm_not_yet_taking_the_cpms_orders_is_not_listening():
    connected = [False]
    live = Liveness(dpm_timeout=2.0, sensor_timeout=1.0, started=0.0,
                    listening=lambda: connected[0])
    live.on_beat(beat(100.0))
    v = live.verdict(100.5)
    assert not v.ok
    assert v.reason.startswith('dpm not listening')
    assert 'capture_command' in v.reason
    connected[0] = True
    assert live.verdict(100.5) == Verdict(True)
    # a dead DPM is named as such, connected or not
    assert live.verdict(103.0).reason.startswith('dpm not alive')


def test_a_sensor_whose_samples_the_dpm_refuses_is_not_called_silent():
    live = rule()
    live.on_beat(Beat(100.0, '/c/input', 0, math.nan, math.nan, 41,
                      'a sensor_msgs/LaserScan on a sensor_msgs/Range '
                      'topic'))
    v = live.verdict(100.1)
    assert not v.ok and 'silent' not in v.reason
    assert v.reason == ('sensor /c/input delivers samples the DPM refuses '
                        '(41 so far; the last: a sensor_msgs/LaserScan on '
                        'a sensor_msgs/Range topic)')


def test_heartbeat_older_than_dpm_timeout_is_dpm_not_alive():
    live = Liveness(2.0, None, 0.0)
    live.on_beat(beat(100.0))
    assert live.verdict(102.0).ok             # at the limit: still alive
    v = live.verdict(102.5)
    assert not v.ok
    assert v.reason == ('dpm not alive: no dpm_state for 2.5 s '
                        '(~dpm_timeout 2.0 s)')


def test_sensor_age_grows_with_the_time_since_the_heartbeat():
    live = rule()
    live.on_beat(beat(100.0, age=0.6))
    assert live.verdict(100.3).ok             # 0.9 s old
    v = live.verdict(100.5)                   # 1.1 s old
    assert not v.ok
    assert v.reason == ('sensor /left/skeleton silent: last sample 1.1 s '
                        'ago (~sensor_timeout 1.0 s)')


def test_a_sensor_that_never_sent_is_named():
    live = rule()
    live.on_beat(beat(100.0, age=math.nan, samples=0, rate=math.nan))
    v = live.verdict(100.1)
    assert not v.ok
    assert v.reason == ('sensor /left/skeleton silent: the DPM has '
                        'received no sample from it')


def test_a_dead_dpm_is_reported_before_its_silent_sensor():
    live = rule()
    live.on_beat(beat(100.0, age=5.0))
    assert live.verdict(103.0).reason.startswith('dpm not alive')


def test_without_a_sensor_only_the_dpm_is_checked():
    live = Liveness(2.0, None, 0.0)
    live.on_beat(beat(100.0, age=math.nan, samples=0))
    assert live.verdict(101.0).ok


def test_a_respawned_dpm_is_alive_again():
    live = rule()
    live.on_beat(beat(100.0))
    assert not live.verdict(110.0).ok
    live.on_beat(beat(111.0, samples=3))      # the new process counts anew
    assert live.verdict(111.2).ok


def test_an_older_heartbeat_than_the_last_is_ignored():
    live = rule()
    assert live.on_beat(beat(100.0))
    assert not live.on_beat(beat(99.0, age=9.0))
    assert live.verdict(100.1).ok


@pytest.mark.parametrize('dpm, sensor', [(0, 1.0), (-1, 1.0), (math.nan, 1),
                                         (math.inf, 1.0), (2.0, 0),
                                         (2.0, -1.0), (2.0, math.inf),
                                         ('2', 1.0)])
def test_bad_timeouts_raise(dpm, sensor):
    with pytest.raises(ValueError, match='timeout'):
        Liveness(dpm, sensor, 0.0)


# The ACK/NACK rule with the verdict

def test_schedule_nacks_with_the_liveness_reason():
    s = ClientSchedule('left', max_uncertainty=0.005)
    reply = s.on_sync(5, 97.5, 98.0, FRESH,
                      Verdict(False, 'dpm not alive: x'))
    assert (reply.ok, reply.reason) == (False, 'dpm not alive: x')
    assert s.acked_round is None
    assert reply.offset == 2.0                # the clock's numbers stay


def test_schedule_acks_when_alive():
    s = ClientSchedule('left', max_uncertainty=0.005)
    assert s.on_sync(5, 97.5, 98.0, FRESH, Verdict(True)).ok
    assert s.acked_round == 5


def test_schedule_names_both_a_clock_and_a_liveness_failure():
    s = ClientSchedule('left', max_uncertainty=0.005)
    reply = s.on_sync(5, 97.5, 98.0, ClockStatus(ClockModel(), 'down', 0),
                      Verdict(False, 'sensor /left/skeleton silent: y'))
    assert not reply.ok
    assert reply.reason == 'down; sensor /left/skeleton silent: y'


# The DPM's side: what its heartbeat reports

def test_sample_meter_before_any_sample():
    samples, age, rate = SampleMeter().state(5.0)
    assert samples == 0 and math.isnan(age) and math.isnan(rate)


def test_sample_meter_age_and_rate():
    m = SampleMeter(window=2.0)
    for i in range(41):                       # 20 Hz for 2 s
        m.on_sample(10.0 + i * 0.05)
    samples, age, rate = m.state(12.1)
    assert samples == 41
    assert age == pytest.approx(0.1)
    assert rate == pytest.approx(20.0, rel=0.03)


def test_sample_meter_silent_sensor_has_no_rate_but_an_age():
    m = SampleMeter(window=2.0)
    for i in range(10):
        m.on_sample(10.0 + i * 0.05)
    samples, age, rate = m.state(20.0)
    assert samples == 10
    assert age == pytest.approx(9.55)
    assert math.isnan(rate)


def test_health_for_diagnostics():
    live = rule(started=99.0)
    h = live.health(100.0)
    assert h.level == 2 and h.message.startswith('dpm not alive')
    assert h.message.endswith(': NACKs')
    live.on_beat(beat(100.0, age=0.05, rate=20.0))
    h = live.health(100.5)
    assert (h.level, h.message) == (
        0, 'dpm alive, sensor /left/skeleton at 20.0 Hz')
    assert h.value('sample_age') == '0.550'
    assert h.value('dpm_state_age') == '0.500'
    h = live.health(101.5)
    assert h.level == 2 and 'sensor /left/skeleton silent' in h.message


def test_a_silent_sensor_says_what_its_driver_said():
    live = rule()
    live.on_beat(beat(100.0, age=3.0))
    assert live.verdict(100.0).reason == (
        'sensor /left/skeleton silent: last sample 3.0 s ago '
        '(~sensor_timeout 1.0 s)')
    assert live.on_driver_status(99.5, 1, 'not tracking:\n  no user')
    assert live.verdict(100.0).reason == (
        'sensor /left/skeleton silent: last sample 3.0 s ago '
        '(~sensor_timeout 1.0 s); its driver said 0.5 s ago: WARN not '
        'tracking: no user')
    live.on_beat(Beat(101.0, '/left/skeleton', 0, math.nan, math.nan))
    assert live.verdict(101.0).reason.endswith(
        'no sample from it; its driver said 1.5 s ago: WARN not tracking: '
        'no user')
    live.on_beat(beat(102.0))
    assert live.verdict(102.0).ok           # delivering: no driver note


def test_a_driver_status_that_is_not_one_is_counted():
    live = rule()
    for level, message in ((7, 'x'), (None, 'x'), (1.0, 'x'), (2, None)):
        assert not live.on_driver_status(100.0, level, message)
    assert live.on_driver_status(100.0, 3, 'y' * 1000)
    assert live.driver == (100.0, 3, 'y' * 300)
    assert live.health(100.0).value('driver_statuses_rejected') == '4'
