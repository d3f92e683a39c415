"""hri_sync.clock.sync: the resync loop, holdover and, with the
CPM's ClientSchedule, ACK/NACK while the time server is away; all on a
fake local clock."""

import math

import pytest

from hri_sync.clock.model import OffsetMeasurement
from hri_sync.clock.sync import ClockSync, SyncError
from hri_sync.clock.ntp import NtpError
from hri_sync.client_process.schedule import ClientSchedule

OFFSET = 1.7        # global minus local of the simulated host, s
DELAY = 0.002       # round trip of every burst: +/- 1 ms
DOWN = 'time server 127.0.0.1:11123 did not answer within 0.50 s'


class FakeHost:
    """A local clock that moves only when slept on, and a time server that
    can be switched off."""

    def __init__(self, t=1000.0):
        self.t = t
        self.server_up = True
        self.measured = []      # local times of every measurement tried

    def clock(self):
        return self.t

    def sleep(self, s):
        assert s > 0
        self.t += s

    def measure(self):
        self.measured.append(self.t)
        if not self.server_up:
            raise NtpError(DOWN)
        return OffsetMeasurement(self.t, OFFSET, DELAY, 8)


def make(host, **kw):
    return ClockSync(host.measure, host.clock, **kw)


def run_until(sync, host, end, report=None):
    """Run the resync loop until local time ``end``."""
    sync.run(host.sleep, lambda: host.t >= end, report or (lambda s: None))


# -- the resync loop -------------------------------------------------------

def test_resync_loop_backs_off_from_half_a_second_to_the_period():
    host = FakeHost(1000.0)
    statuses = []
    run_until(make(host, resync_period=5.0), host, 1030.0, statuses.append)
    assert [t - 1000.0 for t in host.measured] == [
        0.0, 0.5, 1.5, 3.5, 7.5, 12.5, 17.5, 22.5, 27.5]
    assert [s.samples for s in statuses] == list(range(1, 10))
    assert all(s.ok and s.error == '' for s in statuses)


def test_resync_loop_with_a_short_period_never_waits_longer():
    host = FakeHost(0.0)
    run_until(make(host, resync_period=0.75, first_pause=0.5), host, 3.0)
    assert host.measured == [0.0, 0.5, 1.25, 2.0, 2.75]


def test_resync_loop_stops_without_sleeping_once_stopped():
    host = FakeHost(0.0)
    sync = make(host)
    sync.run(host.sleep, lambda: len(host.measured) >= 1, lambda s: None)
    assert host.measured == [0.0] and host.t == 0.0


def test_resync_loop_keeps_measuring_while_the_server_is_down():
    host = FakeHost(0.0)
    host.server_up = False
    statuses = []
    run_until(make(host, resync_period=5.0), host, 20.0, statuses.append)
    assert host.measured == [0.0, 0.5, 1.5, 3.5, 7.5, 12.5, 17.5]
    assert all(not s.ok and s.error == DOWN for s in statuses)
    assert statuses[-1].reason(host.t) == DOWN


@pytest.mark.parametrize('kw', [{'resync_period': 0.0},
                                {'resync_period': math.nan},
                                {'first_pause': -1.0},
                                {'drift_bound': -1e-6}])
def test_bad_settings_are_refused(kw):
    with pytest.raises(ValueError):
        make(FakeHost(), **kw)


# -- one measurement -------------------------------------------------------

def test_before_any_measurement_there_is_no_model():
    s = make(FakeHost()).status()
    assert not s.ok and s.samples == 0
    assert s.reason(0.0) == 'not measured yet'


@pytest.mark.parametrize('error', [SyncError('chronyc makestep failed'),
                                   OSError('network is unreachable'),
                                   ValueError('inconsistent NTP sample')])
def test_a_failed_measurement_is_kept_as_the_reason(error):
    def measure():
        raise error
    sync = ClockSync(measure, lambda: 5.0)
    s = sync.sync()
    assert not s.ok and s.error == str(error) == sync.last_error


def test_a_bug_in_the_measurement_is_not_swallowed():
    def measure():
        raise KeyError('bug')
    with pytest.raises(KeyError):
        ClockSync(measure, lambda: 5.0).sync()


def test_status_is_a_copy_not_the_live_fit():
    host = FakeHost(100.0)
    sync = make(host)
    first = sync.sync()
    host.t = 110.0
    sync.sync()
    assert first.model.local_ref == 100.0 and first.samples == 1
    assert sync.status().model.local_ref == 110.0


def test_latest_is_read_without_waiting_for_a_measurement_in_progress():
    host = FakeHost(100.0)
    seen = []

    def measure():      # runs with the sync's lock held
        seen.append(sync.latest)
        return host.measure()
    sync = ClockSync(measure, host.clock)
    assert not sync.latest.ok and sync.latest.error == 'not measured yet'
    first = sync.sync()
    assert sync.latest == first and first.ok
    host.t = 105.0
    host.server_up = False
    second = sync.sync()
    assert seen == [seen[0], first]
    assert not seen[0].ok
    assert sync.latest == second and second.error == DOWN
    assert second.model.local_ref == 100.0


# -- holdover ----------------------------------------------------------------

def test_holdover_keeps_the_model_and_grows_its_uncertainty():
    host = FakeHost(100.0)
    sync = make(host, drift_bound=1e-4)
    sync.sync()
    host.server_up = False
    host.t = 130.0
    s = sync.sync()
    assert s.ok and s.error == DOWN and s.samples == 1
    assert s.model.offset == OFFSET and s.model.local_ref == 100.0
    assert s.model.uncertainty_at(130.0) == pytest.approx(0.004, abs=1e-15)
    assert s.reason(130.0) == ('holdover: no good sync for 30.0 s (%s); '
                               'uncertainty 4.000 ms' % DOWN)
    # Published at 130, the model carries the bound of that instant.
    assert s.model.snapshot(130.0).uncertainty == pytest.approx(0.004,
                                                                abs=1e-15)
    # The server is back: fresh again, the growth restarts.
    host.server_up = True
    host.t = 131.0
    s = sync.sync()
    assert s.error == '' and s.reason(131.0) == ''
    assert s.model.uncertainty_at(131.0) == pytest.approx(0.001, abs=1e-15)


def test_cpm_acks_in_holdover_then_nacks_past_max_uncertainty():
    # The CPM measures on every sync_time; the time server dies at 100 s.
    # With +/- 1 ms and 100 ppm of growth the bound passes 5 ms 40 s later.
    host = FakeHost(90.0)
    sync = make(host, drift_bound=1e-4)
    cpm = ClientSchedule('alice', max_uncertainty=0.005)
    replies = {}
    for n, t in enumerate([90.0, 100.0, 120.0, 139.0, 141.0, 150.0, 151.0],
                          start=1):
        host.t = t
        host.server_up = t < 101.0 or t > 150.5
        replies[t] = cpm.on_sync(n, t, t, sync.sync())
    assert [replies[t].ok for t in sorted(replies)] == [
        True, True, True, True, False, False, True]
    assert replies[100.0].reason == ''
    assert replies[120.0].reason.startswith(
        'holdover: no good sync for 20.0 s')
    assert replies[141.0].reason == (
        'offset uncertainty 5.10 ms exceeds ~max_uncertainty 5.00 ms; no '
        'good sync for 41.0 s: %s' % DOWN)
    assert replies[151.0].reason == ''
    assert replies[151.0].uncertainty == pytest.approx(0.001, abs=1e-12)
    # Every reply while the server was away still names the global time.
    assert replies[141.0].stamp == pytest.approx(141.0 + OFFSET, abs=1e-9)


def test_status_carries_the_round_trip_of_the_measurement_just_made():
    host = FakeHost(1000.0)
    sync = make(host)
    assert math.isnan(sync.status().round_trip)     # nothing measured yet
    assert sync.sync().round_trip == DELAY
    host.server_up = False
    assert math.isnan(sync.sync().round_trip)       # the burst failed
