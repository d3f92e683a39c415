"""The host clocks checked (hri_sync.clock.host_clock, preflight): the
system clock's offset to the time server, chrony's estimate and the
model's, graded against the documented thresholds; and, under
libfaketime, a process whose clock is 2.5 s ahead is reported and warned
about by preflight's core."""
import math
import os
import shutil
import subprocess
import sys
import time
from types import SimpleNamespace as NS

import pytest

from hri_sync.clock import host_clock
from hri_sync.wire.health import ERROR, OK, WARN
from hri_sync.clock.host_clock import (Chrony, HostClock, chrony_tracking,
                                       grade, health, parse_tracking)
from hri_sync.tools.preflight import (Client, Clock, Limits, Site, assess,
                                      client_host_clock)
from test_ntp import FakeNtpServer, server_reply

ROOT = os.path.join(os.path.dirname(__file__), '..', '..')
# chronyc -c tracking of a chronyd 0.150 s fast (chrony 4.3, this machine)
TRACKING = ('7F000001,127.0.0.1,9,1795588190.182155768,-0.150004476,'
            '-0.000007018,0.000007674,1.643,-0.312,10.483,0.299933285,'
            '0.000041079,1.0,Normal\n')


def test_parse_tracking_reads_the_system_time_offset_with_its_sign():
    c = parse_tracking(TRACKING)
    assert c.available
    assert c.offset == pytest.approx(-0.150004476)
    assert (c.reference, c.stratum, c.leap) == ('127.0.0.1', 9, 'Normal')


def test_parse_tracking_unsynchronised_and_garbage():
    c = parse_tracking('00000000,,0,0.0,0.0,0.0,0.0,0.0,0.0,0.0,1.0,1.0,'
                       '0.0,Not synchronised\n')
    assert not c.available and 'not synchronised' in c.reason
    assert math.isnan(c.offset)
    assert not parse_tracking('506 Cannot talk to daemon').available
    # hri_sync's time_server (chronyd, local stratum 8) answering chronyc
    local = parse_tracking('7F7F0101,,8,1795588332.860155297,0.000000000,'
                           '0.0,0.0,0.000,0.000,0.000,0.0,0.0,0.0,Normal')
    assert local.reason == ('unavailable: chronyd here serves its own clock '
                            '(local stratum 8), it follows no source')
    assert not parse_tracking('a,b,c,d,e,f,g,h,i,j,k,l,m,n').available


def test_chrony_tracking_says_why_it_is_unavailable():
    def fails(cmd, **kw):
        return NS(returncode=1, stdout='',
                  stderr='506 Cannot talk to daemon\n')

    def missing(cmd, **kw):
        raise FileNotFoundError(cmd[0])

    def answers(cmd, **kw):
        assert cmd == ['chronyc', '-c', 'tracking']
        return NS(returncode=0, stdout=TRACKING, stderr='')
    assert chrony_tracking(fails).reason == \
        'unavailable: 506 Cannot talk to daemon'
    assert chrony_tracking(missing).reason == \
        'unavailable: chronyc is not installed'
    assert chrony_tracking(answers).offset == pytest.approx(-0.150004476)


@pytest.mark.skipif(not shutil.which('chronyc'), reason='no chronyc')
def test_chronyc_without_a_daemon_is_reported_unavailable():
    c = chrony_tracking(command=('chronyc', '-h', '127.0.0.1', '-p', '1',
                                 '-c', 'tracking'))
    assert c.reason.startswith('unavailable: ')


@pytest.mark.parametrize('offset,level', [
    (0.0, OK), (0.004, OK), (-0.0049, OK), (0.006, WARN), (-0.049, WARN),
    (0.051, ERROR), (-2.5, ERROR), (math.nan, ERROR)])
def test_grade_by_the_documented_thresholds(offset, level):
    assert (host_clock.WARN_OFFSET, host_clock.ERROR_OFFSET) == (0.005, 0.05)
    assert grade(offset) == level


def test_health_grades_the_measured_offset_and_shows_all_three():
    h = health(HostClock('pc1', 0.012, 0.0004, '', 0.0119,
                         Chrony(0.0121, 'ntp1', 2, 'Normal')))
    assert h.level == WARN
    assert h.message.startswith('system clock +12.000 ms off the time '
                                'server (measured by SNTP); above 5 ms: tf')
    v = dict(h.values)
    assert (v['host'], v['system_clock_offset_ms'], v['model_offset_ms'],
            v['chrony_offset_ms']) == ('pc1', '+12.000 ms', '+11.900 ms',
                                       '+12.100 ms')


def test_health_falls_back_to_chrony_then_the_model():
    unreachable = 'time server 10.0.0.1:123 did not answer within 0.50 s'
    h = health(HostClock('pc1', error=unreachable, model_offset=0.001,
                         chrony=Chrony(0.08, 'ntp1', 2, 'Normal')))
    assert h.level == ERROR and '(by chrony)' in h.message
    assert dict(h.values)['system_clock_error'] == unreachable
    h = health(HostClock('pc1', error=unreachable, model_offset=0.001,
                         chrony=Chrony(reason='unavailable: no chronyd')))
    assert h.level == OK and "(by hri_sync's clock model)" in h.message
    assert dict(h.values)['chrony_offset_ms'] == 'unavailable: no chronyd'
    h = health(HostClock('pc1', error=unreachable))
    assert h.level == ERROR
    assert h.message == 'system clock offset unknown: ' + unreachable


def test_measure_records_a_failed_burst():
    def burst():
        raise OSError('network is unreachable')
    h = host_clock.measure('pc1', burst, 0.002,
                           lambda: Chrony(reason='unavailable: x'))
    assert h.error == 'network is unreachable'
    assert math.isnan(h.system_offset) and h.model_offset == 0.002


SYNCED = Clock(ok=True, uncertainty=0.0004, drift=12e-6, samples=3)


def site(**kw):
    return Site(window=3.0, time_server='10.0.0.1:11123', clients=[
        Client('left', Clock(True, '', 0.0004, 0.0, 3, offset=-2.5)),
        Client('right', SYNCED, host_clock={
            'host': 'pc2', 'system_clock_offset_ms': '+0.300 ms',
            'system_clock_round_trip_ms': '+0.200 ms',
            'chrony_offset_ms': '+0.250 ms'})], **kw)


def test_preflight_warns_per_host_but_stays_go():
    r = assess(site(host_clock=HostClock('server', 0.0001, 0.0002, '', 0.0,
                                         Chrony(reason='unavailable: x'))))
    assert r.go, r.text()
    text = r.text()
    assert ('this host (host server): OK system clock +0.100 ms off the '
            'time server (measured by SNTP); model +0.000 ms, chrony '
            'unavailable: x') in text
    assert ('right (host pc2): OK system clock +0.300 ms off the time '
            'server (measured by SNTP); model n/a, chrony +0.250 ms') in text
    assert r.warnings == [
        "left (host left): system clock -2500.000 ms off the time server "
        "(by hri_sync's clock model); above 50 ms: tf extrapolation errors "
        "and mispaired message_filters between hosts; set it with chrony "
        "(docs/host_clocks.md)"]
    assert text.endswith('\npreflight: GO')
    assert '\nwarning: left (host left): system clock -2500.000 ms' in text


def test_preflight_no_go_on_a_far_clock_when_asked():
    r = assess(site(), Limits(system_clock_no_go=True))
    assert not r.go
    assert r.reasons[0].startswith('left (host left): system clock -2500')


def test_client_host_clock_sources():
    assert client_host_clock(Client('a', SYNCED)) is None
    assert client_host_clock(Client('a')) is None
    hc = client_host_clock(site().clients[1])
    assert (hc.host, hc.system_offset, hc.chrony.offset) == (
        'pc2', pytest.approx(0.0003), pytest.approx(0.00025))


def true_time_reply(request):
    """An SNTP reply stamped with this (unfaked) process's clock."""
    now = time.time()
    return server_reply(now, now)(request)


PREFLIGHT_HOST = '''
import sys, time
sys.path.insert(0, %r)
from hri_sync.clock import host_clock
from hri_sync.clock.ntp import measure
from hri_sync.tools.preflight import Site, assess
hc = host_clock.measure('faked', lambda: measure('127.0.0.1', %d, 4, 1.0,
                                                 time.time))
print(assess(Site(1.0, '127.0.0.1:%d', hc.error or None,
                  host_clock=hc)).text())
'''


@pytest.mark.skipif(not shutil.which('faketime'), reason='no libfaketime')
def test_preflight_reports_and_warns_on_a_clock_2_5_s_ahead():
    server = FakeNtpServer(true_time_reply)
    try:
        script = PREFLIGHT_HOST % (os.path.join(ROOT, 'src'), server.port,
                                   server.port)
        p = subprocess.run(['faketime', '-f', '+2.5s', sys.executable, '-c',
                            script], capture_output=True, text=True,
                           timeout=120)
        honest = subprocess.run([sys.executable, '-c', script],
                                capture_output=True, text=True, timeout=120)
    finally:
        server.close()
    assert p.returncode == 0, p.stderr
    line = [x for x in p.stdout.splitlines()
            if x.startswith('this host (host faked)')][0]
    offset_ms = float(line.split('system clock ')[1].split(' ms')[0])
    assert offset_ms == pytest.approx(-2500, abs=50)
    assert line.startswith('this host (host faked): ERROR system clock -2')
    assert '\nwarning: this host (host faked): system clock -2' in p.stdout
    assert 'above 50 ms' in p.stdout and p.stdout.endswith('GO\n')
    assert 'this host (host faked): OK system clock' in honest.stdout
    assert 'warning' not in honest.stdout
