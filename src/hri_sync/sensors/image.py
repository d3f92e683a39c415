"""sensor_msgs/Image: decoding with checks, and motion energy.

Encodings (REP 118 for depth): ``rgb8``, ``bgr8``, ``rgba8``, ``bgra8``,
``mono8``, ``mono16`` (intensity, scaled to full scale = 1), ``16UC1``
(depth in mm, 0 = no reading) and ``32FC1`` (depth in m, NaN, inf or 0 =
no reading), either byte order (``is_bigendian``).
"""
import numpy as np

from hri_sync.sensors.base import HeaderStamped
from hri_sync.data_process.processors import ProcessResult
from hri_sync.wire.validate import Rejected

# encoding: (dtype, channels, scale to the result's unit, depth?)
ENCODINGS = {
    'rgb8': ('u1', 3, 1 / 255.0, False),
    'bgr8': ('u1', 3, 1 / 255.0, False),
    'rgba8': ('u1', 4, 1 / 255.0, False),
    'bgra8': ('u1', 4, 1 / 255.0, False),
    'mono8': ('u1', 1, 1 / 255.0, False),
    'mono16': ('u2', 1, 1 / 65535.0, False),
    '16UC1': ('u2', 1, 1e-3, True),
    '32FC1': ('f4', 1, 1.0, True),
}
MAX_SIDE = 16384        # pixels: a larger width or height is refused


def check_image(msg):
    """Raise Rejected unless ``msg`` is an image of a known encoding whose
    data is exactly ``step * height`` bytes with ``step`` holding
    ``width`` pixels."""
    enc = msg.encoding
    if enc not in ENCODINGS:
        raise Rejected('unknown_encoding', 'encoding %r is not one of %s'
                       % (str(enc)[:40], ', '.join(ENCODINGS)), 'encoding')
    dtype, channels, _, _ = ENCODINGS[enc]
    h, w, step = msg.height, msg.width, msg.step
    if not (0 < h <= MAX_SIDE and 0 < w <= MAX_SIDE):
        raise Rejected('bad_size', 'image %sx%s: width and height must lie '
                       'within 1..%d' % (w, h, MAX_SIDE), 'width')
    row = w * channels * np.dtype(dtype).itemsize
    if step < row:
        raise Rejected('bad_step', 'step %d < %d bytes of %d %s pixels'
                       % (step, row, w, enc), 'step')
    if len(msg.data) != step * h:
        raise Rejected('size_mismatch', 'data is %d bytes, step x height '
                       '= %d x %d = %d' % (len(msg.data), step, h, step * h),
                       'data')
    if msg.is_bigendian not in (0, 1):
        raise Rejected('malformed', 'is_bigendian=%r' % (msg.is_bigendian,),
                       'is_bigendian')


def image_array(msg):
    """The pixels of a checked image: an array (height, width, channels)
    of its raw type, a view of ``msg.data`` (no copy)."""
    dtype, channels, _, _ = ENCODINGS[msg.encoding]
    dt = np.dtype(dtype).newbyteorder('>' if msg.is_bigendian else '<')
    rows = np.frombuffer(msg.data, np.uint8).reshape(msg.height, msg.step)
    row = msg.width * channels * dt.itemsize
    return rows[:, :row].view(dt).reshape(msg.height, msg.width, channels)


class ImageMotion(HeaderStamped):
    """Motion energy of an image stream: the mean absolute change between
    consecutive frames, per second of window.

    value = sum over consecutive frame pairs k of mean |I_k - I_(k-1)| / T

    with the mean over the pixels (of ``roi``, every ``stride``-th row and
    column) and channels, and T the window (s).  Unit: m/s for depth
    (16UC1, 32FC1; only pixels with a reading in both frames count),
    full scale per second (1/s) for intensity (a pixel going from black to
    white and back in one second: 2/s).  A dropped frame widens its
    pair's change, so the value does not depend on the frame rate for
    smooth motion; sensor noise does add per frame pair (``median_change``
    in the diagnostics: the median pair's mean change).

    ``~processor_params``: ``roi`` [x, y, width, height] pixels (default
    the whole frame), ``stride`` (default 1).  A frame whose size or
    encoding differs from the previous one starts the pairs over
    (``size_changes``); a pair without a common depth reading adds
    nothing (``empty_pairs``).
    """

    msg_type = 'sensor_msgs/Image'
    topic = 'image'

    def __init__(self, roi=None, stride=1):
        super().__init__()
        if roi is not None:
            roi = [int(v) for v in roi]
            if len(roi) != 4 or min(roi) < 0 or roi[2] < 1 or roi[3] < 1:
                raise ValueError('roi must be [x, y, width, height] pixels, '
                                 'got %r' % (roi,))
        if int(stride) < 1:
            raise ValueError('stride must be >= 1, got %r' % (stride,))
        self.roi = roi
        self.stride = int(stride)
        self.begin(0.0, 0.0)

    def check(self, msg):
        check_image(msg)
        if self.roi is not None:
            x, y, w, h = self.roi
            if x + w > msg.width or y + h > msg.height:
                raise Rejected('roi_outside', 'roi %r lies outside the %dx%d '
                               'image' % (self.roi, msg.width, msg.height),
                               'roi')

    def begin(self, start, end):
        self._duration = end - start
        self._prev = None
        self._key = None
        self._sum = 0.0
        self._changes = []
        self._frames = 0
        self._size_changes = 0
        self._empty = 0

    def _pixels(self, msg):
        a = image_array(msg)
        if self.roi is not None:
            x, y, w, h = self.roi
            a = a[y:y + h, x:x + w]
        s = self.stride
        return a[::s, ::s]

    def add(self, frame):
        msg = frame.msg
        key = (msg.encoding, msg.width, msg.height)
        _, _, scale, depth = ENCODINGS[msg.encoding]
        cur = self._pixels(msg)
        if depth:
            cur = cur.astype(np.float32)
            cur = np.where(np.isfinite(cur) & (cur > 0), cur * scale, np.nan)
        elif cur.dtype.kind == 'u':     # exact, and 5x faster than floats
            cur = cur.astype(np.int16 if cur.itemsize == 1 else np.int32)
        else:
            cur = cur.astype(np.float32)
        self._frames += 1
        prev, self._prev = self._prev, cur
        if key != self._key:
            if self._key is not None:
                self._size_changes += 1
            self._key = key
            return
        diff = np.abs(cur - prev)
        if depth:
            valid = diff[np.isfinite(diff)]
            if not valid.size:
                self._empty += 1
                return
            change = float(valid.mean())
        else:
            total = diff.sum(dtype=np.int64 if diff.dtype.kind == 'i'
                             else np.float64)
            change = float(total) / diff.size * scale
        self._sum += change
        self._changes.append(change)

    def result(self):
        changes = self._changes
        return ProcessResult(
            value=self._sum / self._duration if self._duration > 0 else 0.0,
            frames_used=self._frames, frames_rejected=0,
            diagnostics={'pairs': len(changes),
                         'median_change': (float(np.median(changes))
                                         if changes else float('nan')),
                         'size_changes': self._size_changes,
                         'empty_pairs': self._empty,
                         'encoding': self._key[0] if self._key else '',
                         'unit': 'm/s' if self._key and
                         ENCODINGS[self._key[0]][3] else '1/s',
                         'T': self._duration})
