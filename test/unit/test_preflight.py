"""Preflight verdicts (hri_sync.tools.preflight)."""
from hri_sync.tools.preflight import (Client, Clock, Limits, Site, assess,
                                      rate)

SYNCED = Clock(ok=True, uncertainty=0.0004, drift=12e-6, samples=3)


def good_site():
    return Site(window=3.0, time_server='10.0.0.1:11123', clients=[
        Client('left', SYNCED, '/left/skeleton', sensor_messages=60),
        Client('right', SYNCED, '/right/skeleton', sensor_messages=59,
               device_clock={'device_clock_drift_ppm': '3.1'}),
        Client('dj_rob', SYNCED), Client('music', SYNCED)],
        robot_id='dj_rob', odom_messages=150)


def test_rate():
    assert rate(60, 3.0) == 20.0
    assert rate(0, 3.0) == 0.0
    assert rate(5, 0.0) == 0.0


def test_go_lists_every_client():
    r = assess(good_site())
    assert r.go and r.reasons == []
    text = r.text()
    assert text.endswith('preflight: GO')
    for what in ('time server 10.0.0.1:11123: answers',
                 'left: clock +/-0.40 ms, drift +12.0 ppm (3 bursts); '
                 'sensor /left/skeleton 20.0 Hz',
                 'device clock device_clock_drift_ppm 3.1',
                 'robot dj_rob: /odom 50.0 Hz'):
        assert what in text


def test_unreachable_time_server_is_no_go_naming_it():
    site = good_site()
    site.time_server_error = ('time server 10.0.0.1:11123 did not answer '
                              'within 1.00 s')
    for c in site.clients:
        c.clock = Clock(ok=False, reason='time server 10.0.0.1:11123 did '
                        'not answer within 0.50 s')
    r = assess(site)
    assert not r.go
    assert r.reasons[0] == ('time server unreachable: time server '
                            '10.0.0.1:11123 did not answer within 1.00 s')
    assert 'left clock not synced: time server 10.0.0.1:11123' in r.reasons[1]
    assert 'NO-GO: time server unreachable: time server 10.0.0.1' in r.text()


def test_silent_and_slow_sensors():
    site = good_site()
    site.clients[0].sensor_messages = 0
    site.clients[1].sensor_messages = 6
    r = assess(site)
    assert not r.go
    assert r.reasons == [
        'left sensor /left/skeleton silent: 0.0 Hz in 3.0 s (needs 5.0)',
        'right sensor /right/skeleton too slow: 2.0 Hz in 3.0 s (needs 5.0)']


def test_client_not_up():
    site = good_site()
    site.clients[3].clock = None
    r = assess(site)
    assert r.reasons == ['music is not up: no /music/clock_state']
    assert 'music: NOT UP (no /music/clock_state)' in r.lines


def test_clock_limits():
    site = good_site()
    site.clients[0].clock = Clock(ok=True, uncertainty=0.008, drift=2e-3,
                                  samples=1)
    r = assess(site, Limits(max_uncertainty=0.005, max_drift=1e-3))
    assert r.reasons == ['left clock uncertainty 8.00 ms > 5.00 ms',
                         'left clock drift +2000 ppm beyond +/-1000 ppm']
    site.clients[0].clock.uncertainty = float('nan')
    site.clients[0].clock.drift = 0.0
    assert not assess(site).go      # an unknown uncertainty is not go


def test_robot_that_does_not_answer():
    site = good_site()
    site.odom_messages = 0
    r = assess(site)
    assert r.reasons == ['robot dj_rob does not answer: /odom 0.0 Hz in '
                         '3.0 s (needs 1.0)']
    site.robot_id = ''
    assert assess(site).go          # no robot expected: no robot check
