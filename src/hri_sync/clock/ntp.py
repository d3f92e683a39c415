"""A minimal SNTP client (RFC 4330) that returns raw NtpSamples.

No ROS.  The local clock is injectable so the sample's t1 and t4 are read
from the same clock the caller corrects.
"""

from __future__ import annotations

import socket
import struct
import time
from typing import Callable, TYPE_CHECKING

from hri_sync.clock.model import NtpSample, best_offset
from hri_sync.clock.sync import SyncError

if TYPE_CHECKING:
    from hri_sync.clock.model import OffsetMeasurement

NTP_EPOCH_OFFSET = 2208988800  # 1900-01-01 to 1970-01-01, s
_PACKET = struct.Struct('!B B b b 11I')


class NtpError(SyncError):
    """The time server could not be queried."""


def _to_ntp(t: float) -> tuple[int, int]:
    seconds = int(t) + NTP_EPOCH_OFFSET
    return seconds, int((t - int(t)) * 2 ** 32) & 0xffffffff


def _from_ntp(seconds: int, fraction: int) -> float:
    return seconds - NTP_EPOCH_OFFSET + fraction / 2 ** 32


def query(server: str, port: int = 123, timeout: float = 0.5,
          local_clock: Callable = time.time) -> NtpSample:
    """Make one NTP exchange and return its NtpSample.

    Raises NtpError with a specific reason when the server does not answer,
    refuses, or answers with a malformed or unsynchronised packet.
    """
    try:
        addr = socket.getaddrinfo(server, port, 0, socket.SOCK_DGRAM)[0][4]
    except (socket.gaierror, UnicodeError) as e:
        raise NtpError('cannot resolve time server %s: %s' % (server, e))
    with socket.socket(socket.AF_INET6 if ':' in addr[0] else socket.AF_INET,
                       socket.SOCK_DGRAM) as sock:
        sock.settimeout(timeout)
        t1 = local_clock()
        tx_s, tx_f = _to_ntp(t1)
        # LI=0, VN=4, mode=3 (client); our transmit time as the origin.
        packet = _PACKET.pack(0x23, 0, 0, 0, *([0] * 9), tx_s, tx_f)
        try:
            sock.sendto(packet, addr)
            data, _ = sock.recvfrom(512)
        except socket.timeout:
            raise NtpError('time server %s:%d did not answer within %.2f s'
                           % (server, port, timeout))
        except OSError as e:
            raise NtpError('time server %s:%d unreachable: %s'
                           % (server, port, e.strerror or e))
        t4 = local_clock()
    if len(data) < _PACKET.size:
        raise NtpError('short NTP reply (%d bytes) from %s:%d'
                       % (len(data), server, port))
    fields = _PACKET.unpack(data[:_PACKET.size])
    li_vn_mode, stratum = fields[0], fields[1]
    words = fields[4:]
    if li_vn_mode & 0x7 != 4:
        raise NtpError('NTP reply from %s:%d is not a server reply (mode %d)'
                       % (server, port, li_vn_mode & 0x7))
    if stratum == 0 or (li_vn_mode >> 6) == 3:
        raise NtpError('time server %s:%d is not synchronised (stratum %d)'
                       % (server, port, stratum))
    if (words[5], words[6]) != (tx_s, tx_f):
        raise NtpError('NTP reply from %s:%d does not match our request'
                       % (server, port))
    if (words[9], words[10]) == (0, 0):
        raise NtpError('NTP reply from %s:%d has no transmit time'
                       % (server, port))
    t2 = _from_ntp(words[7], words[8])
    t3 = _from_ntp(words[9], words[10])
    return NtpSample(t1, t2, t3, t4)


def measure(server: str, port: int = 123, exchanges: int = 8,
            timeout: float = 0.5, local_clock: Callable = time.time,
            pause: float = 0.01) -> OffsetMeasurement:
    """Make a burst of exchanges; return the minimum-delay OffsetMeasurement.

    Exchanges that fail are skipped; if none answers, NtpError carries the
    last reason.
    """
    samples: list[NtpSample] = []
    last_error = NtpError('no exchange made')
    for i in range(exchanges):
        try:
            samples.append(query(server, port, timeout, local_clock))
        except NtpError as e:
            last_error = e
            if not samples and i >= 1:
                break  # two failures in a row with no answer: give up fast
        if pause:
            time.sleep(pause)
    if not samples:
        raise last_error
    return best_offset(samples)
