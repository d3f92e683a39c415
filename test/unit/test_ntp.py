"""hri_sync.clock.ntp: the SNTP client against a fake server on loopback UDP
(and a real chronyd when one is installed)."""

import os
import shutil
import socket
import struct
import subprocess
import threading
import time

import pytest

from hri_sync.clock import ntp
from hri_sync.clock.model import NtpSample

PACKET = struct.Struct('!B B b b 11I')
# s: a call that has not returned by then hangs; a liveness bound far
# beyond any delay load causes (the timeouts here are 0.1-0.3 s).
HANG = 30.0


def to_ntp(t):
    seconds = int(t)
    return seconds + ntp.NTP_EPOCH_OFFSET, int((t - seconds) * 2 ** 32)


class FakeNtpServer:
    """A UDP server on 127.0.0.1 answering with what ``reply`` returns.

    ``reply(request_bytes) -> bytes or None`` (None: stay silent).  Every
    request is recorded in ``requests``.
    """

    def __init__(self, reply, host='127.0.0.1'):
        self.reply = reply
        self.requests = []
        self.sock = socket.socket(
            socket.AF_INET6 if ':' in host else socket.AF_INET,
            socket.SOCK_DGRAM)
        self.sock.bind((host, 0))
        self.sock.settimeout(0.05)
        self.port = self.sock.getsockname()[1]
        self._stop = False
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    def _serve(self):
        while not self._stop:
            try:
                data, addr = self.sock.recvfrom(512)
            except socket.timeout:
                continue
            self.requests.append(data)
            out = self.reply(data)
            if out is not None:
                self.sock.sendto(out, addr)

    def close(self):
        self._stop = True
        self._thread.join(2.0)
        self.sock.close()


def server_reply(t2, t3, mode=4, stratum=2, li=0, origin=None, size=None):
    """A reply builder: receive time t2, transmit time t3 (server clock)."""
    def reply(request):
        req = PACKET.unpack(request[:PACKET.size])
        words = list(req[4:])
        org = (words[9], words[10]) if origin is None else origin
        packet = PACKET.pack((li << 6) | (4 << 3) | mode, stratum, 4, -20,
                             0, 0, 0, 0, 0, org[0], org[1],
                             *to_ntp(t2), *to_ntp(t3))
        return packet[:size] if size is not None else packet
    return reply


@pytest.fixture
def fake_server():
    servers = []

    def start(reply, host='127.0.0.1'):
        s = FakeNtpServer(reply, host)
        servers.append(s)
        return s
    yield start
    for s in servers:
        s.close()


def local_clock(*values):
    """An injected local clock returning ``values`` in turn."""
    it = iter(values)
    return lambda: next(it)


def test_query_returns_the_exchange_timestamps(fake_server):
    srv = fake_server(server_reply(1001.75, 1001.8125))
    s = ntp.query('127.0.0.1', srv.port, timeout=1.0,
                  local_clock=local_clock(1000.0, 1000.25))
    assert isinstance(s, NtpSample)
    assert (s.t1, s.t4) == (1000.0, 1000.25)
    # NTP fractions are 2^-32 s: these values are exact in binary.
    assert (s.t2, s.t3) == (1001.75, 1001.8125)
    assert s.offset == 1.65625
    assert s.delay == 0.1875


def test_request_is_an_sntp_v4_client_packet_with_our_transmit_time(
        fake_server):
    srv = fake_server(server_reply(5.0, 5.0))
    ntp.query('127.0.0.1', srv.port, timeout=1.0,
              local_clock=local_clock(1234.5, 1234.5))
    assert len(srv.requests) == 1
    req = srv.requests[0]
    assert len(req) == 48
    fields = PACKET.unpack(req)
    assert fields[0] == 0x23            # LI 0, VN 4, mode 3 (client)
    assert fields[4 + 9:] == to_ntp(1234.5)


def test_real_time_offset_against_a_fake_server_1_7_s_ahead(fake_server):
    # Receive and transmit stamps are one real reading, so the server
    # holds no time of its own: a fixed processing time (20 us before)
    # exceeded a fast loopback round trip and made the delay negative.
    def reply(request):
        now = time.time() + 1.7
        return server_reply(now, now)(request)
    srv = fake_server(reply)
    m = ntp.measure('127.0.0.1', srv.port, exchanges=4, timeout=1.0,
                    pause=0)
    assert m.exchanges == 4
    # NTP's own bound: the offset is off by at most half the round trip
    # (plus float resolution), however long load makes the trip.
    assert m.delay >= 0
    assert abs(m.offset - 1.7) <= m.delay / 2 + 1e-6
    assert len(srv.requests) == 4


def ipv6_loopback():
    try:
        with socket.socket(socket.AF_INET6, socket.SOCK_DGRAM) as s:
            s.bind(('::1', 0))
        return True
    except OSError:
        return False


@pytest.mark.skipif(not ipv6_loopback(), reason='no IPv6 loopback')
def test_ipv6_server(fake_server):
    srv = fake_server(server_reply(1001.75, 1001.75), host='::1')
    s = ntp.query('::1', srv.port, timeout=1.0,
                  local_clock=local_clock(1000.0, 1000.5))
    assert s.offset == 1.5 and s.delay == 0.5


def test_silent_server_times_out_with_a_reason(fake_server):
    srv = fake_server(lambda request: None)
    t0 = time.monotonic()
    with pytest.raises(ntp.NtpError,
                       match=r'127\.0\.0\.1:%d did not answer within 0\.20 s'
                       % srv.port):
        ntp.query('127.0.0.1', srv.port, timeout=0.2)
    assert time.monotonic() - t0 > 0.15     # it waited for the timeout
    assert time.monotonic() - t0 < HANG     # and returned


def test_measure_gives_up_fast_when_nothing_answers(fake_server):
    srv = fake_server(lambda request: None)
    t0 = time.monotonic()
    with pytest.raises(ntp.NtpError, match='did not answer'):
        ntp.measure('127.0.0.1', srv.port, exchanges=8, timeout=0.1,
                    pause=0)
    # Two failures in a row without an answer: no more attempts.
    assert len(srv.requests) == 2
    assert time.monotonic() - t0 < HANG


def test_nobody_listening_is_an_error_not_a_hang():
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(('127.0.0.1', 0))
        port = s.getsockname()[1]
    # The port is closed now: either refused or silent, never a hang.
    t0 = time.monotonic()
    with pytest.raises(ntp.NtpError, match='127.0.0.1:%d' % port):
        ntp.measure('127.0.0.1', port, exchanges=3, timeout=0.2, pause=0)
    assert time.monotonic() - t0 < HANG


def test_unresolvable_host():
    with pytest.raises(ntp.NtpError, match='cannot resolve time server '
                       'no-such-host.invalid'):
        ntp.query('no-such-host.invalid', 123, timeout=0.2)


def test_short_reply_is_malformed(fake_server):
    srv = fake_server(server_reply(1.0, 1.0, size=40))
    with pytest.raises(ntp.NtpError, match=r'short NTP reply \(40 bytes\) '
                       r'from 127\.0\.0\.1'):
        ntp.query('127.0.0.1', srv.port, timeout=1.0)


def test_reply_that_is_not_a_server_reply(fake_server):
    srv = fake_server(server_reply(1.0, 1.0, mode=3))
    with pytest.raises(ntp.NtpError, match=r'not a server reply \(mode 3\)'):
        ntp.query('127.0.0.1', srv.port, timeout=1.0)


@pytest.mark.parametrize('stratum, li', [(0, 0), (2, 3)])
def test_unsynchronised_server_is_refused(fake_server, stratum, li):
    # Stratum 0 (kiss-o'-death) or leap indicator 3 (alarm).
    srv = fake_server(server_reply(1.0, 1.0, stratum=stratum, li=li))
    with pytest.raises(ntp.NtpError,
                       match=r'is not synchronised \(stratum %d\)' % stratum):
        ntp.query('127.0.0.1', srv.port, timeout=1.0)


def test_reply_with_another_origin_is_refused(fake_server):
    srv = fake_server(server_reply(1.0, 1.0, origin=to_ntp(999.0)))
    with pytest.raises(ntp.NtpError, match='does not match our request'):
        ntp.query('127.0.0.1', srv.port, timeout=1.0,
                  local_clock=local_clock(1000.0, 1000.0))


def test_reply_without_a_transmit_time_is_refused(fake_server):
    # RFC 4330: a zero transmit timestamp is an unusable reply (it would
    # read as an offset of -70 years).
    def reply(request):
        packet = bytearray(server_reply(1.0, 1.0)(request))
        packet[40:48] = bytes(8)
        return bytes(packet)
    srv = fake_server(reply)
    with pytest.raises(ntp.NtpError, match='no transmit time'):
        ntp.query('127.0.0.1', srv.port, timeout=1.0)


def test_measure_keeps_the_minimum_delay_exchange_and_skips_failures(
        fake_server):
    # Replies: bad, ok slow, ok fast, bad, ok medium.  The local clock
    # advances by the round trip we want each exchange to show.
    plan = iter([
        ('bad', 0.0), ('ok', 0.5), ('ok', 0.125), ('bad', 0.0), ('ok', 0.25)])
    current = {}

    def reply(request):
        kind, rtt = current['step']
        if kind == 'bad':
            return server_reply(0.0, 0.0, stratum=0)(request)
        t1 = current['t1']
        return server_reply(t1 + 2.0 + rtt / 2, t1 + 2.0 + rtt / 2)(request)

    times = []

    def clock():
        # Called twice per exchange: t1 (sets up the step), then t4.
        if len(times) % 2 == 0:
            current['step'] = next(plan)
            current['t1'] = 100.0 + len(times)
            times.append(current['t1'])
        else:
            times.append(current['t1'] + current['step'][1])
        return times[-1]

    srv = fake_server(reply)
    m = ntp.measure('127.0.0.1', srv.port, exchanges=5, timeout=1.0,
                    local_clock=clock, pause=0)
    assert len(srv.requests) == 5
    assert m.exchanges == 3           # the two refused ones are skipped
    assert m.delay == 0.125
    assert m.offset == 2.0
    assert m.local == 104.0 + 0.0625  # the third exchange's midpoint


def test_measure_after_a_first_failure_still_measures(fake_server):
    answers = iter([None, 'ok', 'ok'])

    def reply(request):
        if next(answers) is None:
            return None
        now = time.time()
        return server_reply(now, now)(request)
    srv = fake_server(reply)
    m = ntp.measure('127.0.0.1', srv.port, exchanges=3, timeout=1.0, pause=0)
    assert m.exchanges == 2
    assert len(srv.requests) == 3


CHRONYD = shutil.which('chronyd') or (
    '/usr/sbin/chronyd' if os.path.exists('/usr/sbin/chronyd') else None)


@pytest.mark.skipif(CHRONYD is None, reason='chronyd is not installed')
def test_against_a_real_chronyd(tmp_path):
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(('127.0.0.1', 0))
        port = s.getsockname()[1]
    conf = tmp_path / 'chrony.conf'
    conf.write_text('port %d\nbindaddress 127.0.0.1\nallow 127.0.0.1\n'
                    'local stratum 8\ncmdport 0\npidfile %s/chronyd.pid\n'
                    % (port, tmp_path))
    proc = subprocess.Popen([CHRONYD, '-x', '-d', '-f', str(conf)],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    try:
        answered, error, deadline = False, None, time.monotonic() + 10.0
        while not answered and time.monotonic() < deadline:
            if proc.poll() is not None:
                pytest.fail('chronyd exited: %s' % proc.stdout.read())
            try:
                ntp.query('127.0.0.1', port, timeout=0.3)
                answered = True
            except ntp.NtpError as e:   # still starting
                error = e
                time.sleep(0.2)
        assert answered, 'chronyd never answered: %s' % error
        # A generous timeout: a loaded machine may delay chronyd's answer.
        m = ntp.measure('127.0.0.1', port, exchanges=4, timeout=2.0)
        # chronyd reads the same system clock: the offset is 0 within
        # half the round trip (and chronyd's timestamping, < 1 ms).
        assert m.delay >= 0
        assert abs(m.offset) <= m.delay / 2 + 1e-3
        assert m.exchanges == 4
    finally:
        proc.terminate()
        proc.wait(5)
