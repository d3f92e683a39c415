"""LSL's clock agreement on the skew bench's clients (bench/lsl_compare.py).

``python -m hri_sync_support.lsl_bench source NAME RATE``, run under a
client's ``faketime`` spec, is that client's LSL outlet: each sample is
its true time (the raw-syscall CLOCK_MONOTONIC, which libfaketime does not
fake), stamped with local_clock() (faked, as LSL's clock on that host).
``LslRecorder``, in the bench process on the true clock, is the lab's
recorder: an inlet per client, LSL's time_correction polled as
LabRecorder does, and each sample's mapping error three ways:

- ``docs``: stamp + the latest ``time_correction()``, as LSL's docs show
  it for online use;
- ``drift_fit``: stamp + a line fitted (Theil-Sen) through all of the
  run's time_correction estimates, the drift fit LSL's docs suggest
  (pyxdf does one over an XDF file's clock offsets; this is not pyxdf's
  code), i.e. offline, with the whole run's estimates;
- ``online_fit``: stamp + ``hri_sync.sensors.lsl.CorrectionFit`` as
  ``nodes/lsl_inlet`` uses it, with the estimates so far.

Errors are against the truth in the sample: mapped time (the recorder's
LSL clock, the true monotonic clock here) minus true time.
"""
import ctypes
import ctypes.util
import math
import sys
import threading
import time

import pylsl

from hri_sync.sensors.lsl import CorrectionFit, theil_sen
from hri_sync.clock.skew import percentiles
from hri_sync.tools import lsl_io

from .harness import ms

METHODS = ('docs', 'drift_fit', 'online_fit')
MAX_READ = 50e-6    # s: a sample whose truth took longer to read is left out
_LIBC = ctypes.CDLL(ctypes.util.find_library('c') or 'libc.so.6',
                    use_errno=True)
SYS_CLOCK_GETTIME, CLOCK_MONOTONIC = 228, 1     # x86_64


class _Timespec(ctypes.Structure):
    _fields_ = [('tv_sec', ctypes.c_long), ('tv_nsec', ctypes.c_long)]


def true_monotonic():
    """CLOCK_MONOTONIC by the raw system call (libfaketime does not
    intercept it), s."""
    ts = _Timespec()
    if _LIBC.syscall(SYS_CLOCK_GETTIME, CLOCK_MONOTONIC, ctypes.byref(ts)):
        raise OSError(ctypes.get_errno(), 'clock_gettime syscall failed')
    return ts.tv_sec + ts.tv_nsec * 1e-9


def source(name, rate):
    """One client's outlet: [true time, how long reading it took] in,
    local_clock() stamps."""
    outlet = pylsl.StreamOutlet(pylsl.StreamInfo(
        name, 'hri_sync_bench', 2, rate, pylsl.cf_double64, name))
    nxt = time.monotonic()
    while True:
        a = true_monotonic()
        stamp = pylsl.local_clock()
        b = true_monotonic()
        outlet.push_sample([(a + b) / 2, b - a], stamp)
        nxt += 1.0 / rate
        time.sleep(max(0.0, nxt - time.monotonic()))


class Stream:
    """One client's inlet and what it recorded."""

    def __init__(self, client, info):
        self.client = client
        self.inlet = pylsl.StreamInlet(info, max_buflen=30, recover=False)
        self.inlet.open_stream(10.0)
        self.estimates = []     # (local LSL time, correction, rtt)
        self.fit = CorrectionFit()
        self.samples = []       # (stamp, truth, latest tc, online tc)
        self.preempted = 0

    def poll(self):
        c, remote, rtt = lsl_io.time_correction_ex(self.inlet, 5.0)
        if not self.estimates or self.estimates[-1][1] != c:
            self.estimates.append((remote + c, c, rtt))
            self.fit.add(remote + c, c, rtt)
        values, stamps = self.inlet.pull_chunk(timeout=0.0)
        for v, t in zip(values, stamps):
            if v[1] <= MAX_READ:    # else preempted between the reads
                self.samples.append((t, v[0], c, self.fit.correction(t + c)))
            else:
                self.preempted += 1


class LslRecorder:
    """The recorder of every client's outlet, in a thread of its own."""

    def __init__(self, log):
        self.log = log
        self.streams = {}
        self.stop_event = threading.Event()
        self.thread = None
        self.error = None

    def connect(self, names, timeout=60.0):
        """Open an inlet on each client's stream ({client: name})."""
        for client, name in names.items():
            infos = lsl_io.resolve(name=name, timeout=timeout)
            if not infos:
                raise RuntimeError('LSL stream %s of %s not found'
                                   % (name, client))
            self.streams[client] = Stream(client, infos[0])
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self):
        try:
            while not self.stop_event.is_set():
                for s in self.streams.values():
                    s.poll()
                time.sleep(0.02)
        except Exception as e:  # reported in the JSON, not a crash
            self.error = repr(e)

    def stop(self):
        """Stop recording; returns the true wall minus monotonic clock."""
        self.stop_event.set()
        if self.thread:
            self.thread.join(10.0)
        return time.time() - true_monotonic()


def errors(stream, since):
    """{method: [(true time, error)]} of a stream's samples after true
    monotonic time ``since``."""
    est = stream.estimates
    ref = est[-1][0]
    slope, icpt = theil_sen([e[0] - ref for e in est], [e[1] for e in est])
    out = {m: [] for m in METHODS}
    for stamp, truth, latest, online in stream.samples:
        if truth < since:
            continue
        offline = icpt + slope * (stamp + latest - ref)
        offline = icpt + slope * (stamp + offline - ref)   # at its own time
        for m, c in zip(METHODS, (latest, offline, online)):
            out[m].append((truth, stamp + c - truth))
    return out


def at(series, t, within=0.1):
    """The error of the sample of ``series`` nearest true time ``t``."""
    best = min(series, key=lambda p: abs(p[0] - t), default=None)
    return best[1] if best and abs(best[0] - t) <= within else math.nan


def figures(recorder, offset, since, window_starts):
    """The LSL part of the JSON: per method, |error| of every sample and
    the spread over the clients at each window start (global = true wall
    time; ``offset``: true wall minus monotonic), their agreement, as the
    skew bench's clock_skew, in ms."""
    errs = {c: errors(s, since - offset)
            for c, s in recorder.streams.items()}
    window_starts = [w - offset for w in window_starts]
    out = {}
    for m in METHODS:
        spreads, at_starts = [], []
        for w in window_starts:
            e = [at(errs[c][m], w) for c in errs]
            e = [x for x in e if math.isfinite(x)]
            at_starts += [abs(x) for x in e]
            if len(e) >= 2:
                spreads.append(max(e) - min(e))
        out[m] = {
            'clock_skew_ms': ms(percentiles(spreads)),
            'clock_error_at_starts_ms': ms(percentiles(at_starts)),
            'sample_error_ms': ms(percentiles(
                [abs(x) for c in errs for _, x in errs[c][m]])),
        }
    out['estimates'] = {c: len(s.estimates)
                        for c, s in recorder.streams.items()}
    out['samples'] = {c: len(s.samples) for c, s in recorder.streams.items()}
    out['samples_left_out_preempted'] = sum(
        s.preempted for s in recorder.streams.values())
    out['estimate_rtt_ms_p50'] = ms({'p50': percentiles(
        [e[2] for s in recorder.streams.values() for e in s.estimates])[
            'p50']})['p50']
    if recorder.error:
        out['error'] = recorder.error
    return out


if __name__ == '__main__':
    if len(sys.argv) == 4 and sys.argv[1] == 'source':
        source(sys.argv[2], float(sys.argv[3]))
    else:
        sys.exit('usage: python -m hri_sync_support.lsl_bench source NAME '
                 'RATE')
