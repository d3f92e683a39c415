"""hri_sync/AudioChunk: level and voice activity; WAV chunking.

A chunk's ``header.stamp`` is the capture time of its first sample frame
(the sensor host's clock); frame k of the chunk was captured
``k / sample_rate`` s later.  Samples are int16, channels interleaved.
"""
import math
import wave

import numpy as np

from hri_sync.sensors.base import HeaderStamped
from hri_sync.data_process.processors import ProcessResult
from hri_sync.wire.validate import Rejected

FULL_SCALE = 32768.0
FLOOR_DBFS = -120.0     # the level of digital silence
MEASURES = ('voice', 'level')
MAX_CHUNK = 10 ** 6     # samples in one chunk


def dbfs(mean_square):
    """RMS level in dB relative to full scale (a full-scale square wave
    is 0 dBFS, a full-scale sine -3 dBFS), floored at -120 dBFS."""
    if mean_square <= 0:
        return FLOOR_DBFS
    return max(FLOOR_DBFS, 10.0 * math.log10(mean_square
                                             / FULL_SCALE ** 2))


def check_chunk(msg):
    """Raise Rejected unless ``msg`` is a usable AudioChunk."""
    rate, channels, n = msg.sample_rate, msg.channels, len(msg.data)
    if not 1000 <= rate <= 384000:
        raise Rejected('bad_rate', 'sample_rate %r is outside 1000..384000 '
                       'Hz' % (rate,), 'sample_rate')
    if not 1 <= channels <= 64:
        raise Rejected('bad_channels', 'channels %r is outside 1..64'
                       % (channels,), 'channels')
    if n == 0:
        raise Rejected('empty', 'a chunk without samples', 'data')
    if n % channels or n > MAX_CHUNK:
        raise Rejected('wrong_length', '%d samples are not whole frames of '
                       '%d channels (or more than %d)'
                       % (n, channels, MAX_CHUNK), 'data')


class AudioLevel(HeaderStamped):
    """Level and voice activity of an audio stream.

    The window's samples (all channels) are cut into blocks of ``block``
    s (default 0.02) in capture time; a block whose RMS level is above
    ``threshold`` dBFS (default -40) is speech (or any sound that loud).
    ``measure: voice`` (default): value = the share of the window (0..1)
    in such blocks.  ``measure: level``: value = the RMS level of all the
    window's samples, dBFS.  Both are in the diagnostics (``voice_share``,
    ``level_dbfs``).  Set ``threshold`` 10-15 dB above your room's noise
    level (the diagnostics' ``quietest_block_dbfs`` of a silent window).

    The window holds the chunks whose first sample is in it; the samples
    of its last chunk past the window's end are left out.  A chunk that
    does not continue the previous one (a gap or overlap of more than
    half a block) drops the partial block (``gaps``).
    """

    msg_type = 'hri_sync/AudioChunk'
    topic = 'audio'

    def __init__(self, threshold=-40.0, block=0.02, measure='voice'):
        super().__init__()
        if measure not in MEASURES:
            raise ValueError('measure must be one of %s, got %r'
                             % (', '.join(MEASURES), measure))
        if not 0.001 <= float(block) <= 1.0:
            raise ValueError('block must lie within 0.001..1 s, got %r'
                             % (block,))
        self.threshold = float(threshold)
        self.block = float(block)
        self.measure = measure
        self.begin(0.0, 0.0)

    def check(self, msg):
        check_chunk(msg)

    def begin(self, start, end):
        self._start, self._end = start, end
        self._sum2 = 0.0          # of every sample used
        self._n = 0
        self._voiced = 0.0        # s in blocks above the threshold
        self._blocks = 0
        self._quietest = math.inf
        self._part = np.zeros(0)  # mean square per frame of a partial block
        self._next = None         # expected stamp of the next chunk
        self._gaps = 0
        self._chunks = 0

    def add(self, frame):
        msg = frame.msg
        rate, channels = msg.sample_rate, msg.channels
        x = np.asarray(msg.data, dtype=np.float64).reshape(-1, channels)
        # Frames past the window's end are left out.
        keep = int(math.ceil((self._end - frame.stamp) * rate - 1e-9))
        x = x[:max(0, keep)]
        if not len(x):
            return
        self._chunks += 1
        ms = np.mean(x * x, axis=1)     # per frame, over channels
        self._sum2 += float(ms.sum())
        self._n += len(ms)
        size = max(1, int(round(self.block * rate)))
        if self._next is not None and \
                abs(frame.stamp - self._next) > self.block / 2:
            self._gaps += 1
            self._part = np.zeros(0)
        self._next = frame.stamp + len(x) / rate
        ms = np.concatenate((self._part, ms))
        whole = len(ms) // size * size
        if whole:
            levels = ms[:whole].reshape(-1, size).mean(axis=1)
            self._blocks += len(levels)
            db = [dbfs(v) for v in levels]
            self._quietest = min(self._quietest, min(db))
            self._voiced += sum(d > self.threshold for d in db) * size / rate
        self._part = ms[whole:]

    def result(self):
        dur = self._end - self._start
        share = self._voiced / dur if dur > 0 else 0.0
        level = dbfs(self._sum2 / self._n) if self._n else math.nan
        return ProcessResult(
            value=share if self.measure == 'voice' else level,
            frames_used=self._chunks,
            diagnostics={'measure': self.measure, 'voice_share': share,
                         'level_dbfs': level, 'blocks': self._blocks,
                         'quietest_block_dbfs': (
                             self._quietest if self._blocks else math.nan),
                         'threshold_dbfs': self.threshold, 'gaps': self._gaps,
                         'unit': ('voiced share (0-1)'
                                  if self.measure == 'voice' else 'dBFS')})


def read_wav(path):
    """(int16 samples (frames, channels), sample rate) of a 16-bit PCM WAV
    file; ValueError naming the file otherwise."""
    try:
        with wave.open(path, 'rb') as w:
            if w.getsampwidth() != 2:
                raise ValueError('%s: %d-bit samples, need 16-bit PCM'
                                 % (path, 8 * w.getsampwidth()))
            channels, rate = w.getnchannels(), w.getframerate()
            data = np.frombuffer(w.readframes(w.getnframes()), '<i2')
    except (OSError, EOFError, wave.Error) as e:
        raise ValueError('%s: not a readable WAV file: %s' % (path, e))
    if not len(data):
        raise ValueError('%s: no samples' % path)
    return data.reshape(-1, channels), rate


def chunk_at(samples, rate, k, size):
    """Chunk ``k`` (``size`` frames) of ``samples`` played in a loop: the
    frames [k * size, (k + 1) * size) modulo their count, and its first
    frame's time offset ``k * size / rate`` s."""
    n = len(samples)
    idx = (np.arange(size) + k * size) % n
    return samples[idx], k * size / rate
