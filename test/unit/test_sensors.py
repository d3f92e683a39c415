"""hri_sync.sensors: the stock processors on an injected clock (the
frames' global stamps and the window are given, no clock is read)."""
import math
import struct
from types import SimpleNamespace as NS

import numpy as np
import pytest

from hri_sync.sensors.audio import (AudioLevel, check_chunk, chunk_at, dbfs,
                                    read_wav)
from hri_sync.sensors.image import ImageMotion, check_image, image_array
from hri_sync.sensors.imu import ImuActivity
from hri_sync.sensors.joint_state import JointSpeed
from hri_sync.data_process.dpm import DataProcess
from hri_sync.data_process.processors import Frame, load_processor
from hri_sync.wire.validate import Rejected


def stamp(t):
    return NS(secs=int(t), nsecs=int(round((t - int(t)) * 1e9)))


def image(pixels, encoding, bigendian=False, pad=0):
    """A sensor_msgs/Image-like of an array (h, w[, c])."""
    a = np.asarray(pixels)
    h, w = a.shape[:2]
    dt = a.dtype.newbyteorder('>' if bigendian else '<')
    rows = a.astype(dt).reshape(h, -1).view(np.uint8)
    rows = np.hstack([rows, np.zeros((h, pad), np.uint8)])
    return NS(header=NS(stamp=stamp(100.0)), height=h, width=w,
              encoding=encoding, is_bigendian=int(bigendian),
              step=rows.shape[1], data=rows.tobytes())


def run(processor, msgs, stamps, start, end):
    for m in msgs:
        processor.check(m)
    return processor.process([Frame(t, m) for t, m in zip(stamps, msgs)],
                             start, end)


# --- images ----------------------------------------------------------------

def test_image_array_reads_padding_and_byte_order():
    a = np.arange(12, dtype=np.uint16).reshape(3, 4) * 1000
    for big in (False, True):
        msg = image(a, '16UC1', bigendian=big, pad=6)
        check_image(msg)
        assert np.array_equal(image_array(msg)[..., 0], a)


def test_depth_motion_energy_is_metres_per_second():
    # A 4x4 depth image whose every pixel moves 10 mm per frame, 10 frames
    # over a 1 s window: 9 pairs x 0.01 m / 1 s.  Pixels without a reading
    # (0) in either frame do not count.
    frames = []
    for k in range(10):
        a = np.full((4, 4), 1000 + 10 * k, np.uint16)
        a[0, 0] = 0 if k % 2 else 500
        frames.append(image(a, '16UC1'))
    r = run(ImageMotion(), frames, [100.0 + 0.1 * k for k in range(10)],
            100.0, 101.0)
    assert r.value == pytest.approx(0.09)
    assert r.frames_used == 10
    assert r.diagnostics['pairs'] == 9
    assert r.diagnostics['unit'] == 'm/s'


def test_float_depth_nan_is_no_reading():
    a = np.full((2, 2), 1.0, np.float32)
    b = a + 0.5
    b[0, 0] = np.nan
    r = run(ImageMotion(), [image(a, '32FC1'), image(b, '32FC1')],
            [100.0, 100.5], 100.0, 102.0)
    assert r.value == pytest.approx(0.5 / 2.0)


@pytest.mark.parametrize('encoding, channels', [
    ('rgb8', 3), ('bgr8', 3), ('mono8', 1)])
def test_intensity_motion_in_full_scale_per_second(encoding, channels):
    shape = (6, 8, channels) if channels > 1 else (6, 8)
    black, white = np.zeros(shape, np.uint8), np.full(shape, 255, np.uint8)
    r = run(ImageMotion(), [image(black, encoding), image(white, encoding),
                            image(black, encoding)],
            [10.0, 10.5, 11.0], 10.0, 12.0)
    assert r.value == pytest.approx(2 / 2.0)
    assert r.diagnostics['unit'] == '1/s'


def test_still_scene_scores_zero_and_roi_limits_the_region():
    a = np.zeros((10, 10), np.uint8)
    b = a.copy()
    b[0:2, 0:2] = 255              # motion outside the roi only
    r = run(ImageMotion(roi=[5, 5, 5, 5]), [image(a, 'mono8'),
                                            image(b, 'mono8')],
            [1.0, 1.1], 1.0, 2.0)
    assert r.value == 0.0
    r = run(ImageMotion(stride=2), [image(a, 'mono8'), image(a, 'mono8')],
            [1.0, 1.1], 1.0, 2.0)
    assert r.value == 0.0


def test_size_change_starts_the_pairs_over():
    a = np.zeros((4, 4), np.uint8)
    b = np.full((2, 2), 255, np.uint8)
    r = run(ImageMotion(), [image(a, 'mono8'), image(b, 'mono8'),
                            image(b, 'mono8')], [1.0, 1.1, 1.2], 1.0, 2.0)
    assert r.value == 0.0
    assert r.diagnostics['size_changes'] == 1


@pytest.mark.parametrize('change, reason', [
    (dict(encoding='yuv422'), 'unknown_encoding'),
    (dict(encoding='jpeg'), 'unknown_encoding'),
    (dict(data=b'\0' * 31), 'size_mismatch'),
    (dict(data=b'\0' * 33), 'size_mismatch'),
    (dict(step=7), 'bad_step'),
    (dict(width=0), 'bad_size'),
    (dict(height=10 ** 6), 'bad_size'),
    (dict(is_bigendian=7), 'malformed'),
])
def test_bad_images_are_rejected_with_a_reason(change, reason):
    msg = image(np.zeros((4, 4), np.uint16), '16UC1')     # step 8, 32 B
    for k, v in change.items():
        setattr(msg, k, v)
    with pytest.raises(Rejected) as e:
        ImageMotion().check(msg)
    assert e.value.reason == reason


def test_roi_outside_the_image_is_rejected():
    with pytest.raises(Rejected) as e:
        ImageMotion(roi=[2, 2, 4, 4]).check(image(np.zeros((4, 4),
                                                           np.uint8),
                                                  'mono8'))
    assert e.value.reason == 'roi_outside'
    with pytest.raises(ValueError):
        ImageMotion(roi=[0, 0, 0, 1])


# --- IMU -------------------------------------------------------------------

def imu(a, w=(0.0, 0.0, 0.0)):
    return NS(header=NS(stamp=stamp(5.0)),
              linear_acceleration=NS(x=a[0], y=a[1], z=a[2]),
              angular_velocity=NS(x=w[0], y=w[1], z=w[2]))


def test_imu_activity_removes_gravity():
    # Gravity plus +-1 m/s^2 along x: the RMS deviation is 1 m/s^2.
    msgs = [imu((s, 0.0, 9.81), (0.0, 0.0, 2.0)) for s in (1, -1) * 50]
    stamps = [1.0 + 0.01 * k for k in range(100)]
    r = run(ImuActivity(), msgs, stamps, 1.0, 2.0)
    assert r.value == pytest.approx(1.0)
    assert r.diagnostics['angular_rate_rms'] == pytest.approx(2.0)
    r = run(ImuActivity(measure='angular_rate'), msgs, stamps, 1.0, 2.0)
    assert r.value == pytest.approx(2.0)
    still = run(ImuActivity(), [imu((0.0, 0.0, 9.81))] * 10,
                stamps[:10], 1.0, 2.0)
    assert still.value == pytest.approx(0.0, abs=1e-6)


@pytest.mark.parametrize('msg, reason', [
    (imu((math.nan, 0, 9.8)), 'not_finite'),
    (imu((0, 0, 9.8), (0, math.inf, 0)), 'not_finite'),
    (imu((0, 0, 1e6)), 'out_of_range'),
    (imu(('x', 0, 0)), 'not_a_number'),
])
def test_bad_imu_samples_are_rejected(msg, reason):
    with pytest.raises(Rejected) as e:
        ImuActivity().check(msg)
    assert e.value.reason == reason


# --- joint states ------------------------------------------------------------

def joints(names, position=(), velocity=()):
    return NS(header=NS(stamp=stamp(5.0)), name=list(names),
              position=list(position), velocity=list(velocity), effort=[])


def test_joint_speed_from_positions():
    # Joint a turns at 1 rad/s, b stands still: mean over joints of the
    # mean squared speed = (1 + 0) / 2.  The order of names may change.
    msgs, stamps = [], []
    for k in range(11):
        t = 0.1 * k
        names = ('a', 'b') if k % 2 else ('b', 'a')
        pos = {'a': t, 'b': 0.3}
        msgs.append(joints(names, [pos[n] for n in names]))
        stamps.append(10.0 + t)
    r = run(JointSpeed(), msgs, stamps, 10.0, 11.0)
    assert r.value == pytest.approx(0.5)
    assert r.diagnostics['joints'] == 2
    r = run(JointSpeed(joints=['a']), msgs, stamps, 10.0, 11.0)
    assert r.value == pytest.approx(1.0)


def test_joint_speed_from_velocities():
    msgs = [joints(('a', 'b'), (0, 0), (2.0, 0.0))] * 4
    r = run(JointSpeed(source='velocity'), msgs, [1, 2, 3, 4], 0.0, 5.0)
    assert r.value == pytest.approx(2.0)


@pytest.mark.parametrize('msg, reason', [
    (joints(('a', 'b'), (0.0, math.nan)), 'not_finite'),
    (joints(('a', 'b'), (0.0,)), 'wrong_length'),
    (joints((), ()), 'wrong_length'),
    (joints(('a', 'a'), (0.0, 1.0)), 'malformed'),
])
def test_bad_joint_states_are_rejected(msg, reason):
    with pytest.raises(Rejected) as e:
        JointSpeed().check(msg)
    assert e.value.reason == reason


# --- audio -------------------------------------------------------------------

def chunk(samples, rate=16000, channels=1):
    return NS(header=NS(stamp=stamp(1.0)), sample_rate=rate,
              channels=channels, data=list(np.asarray(samples).ravel()))


def test_dbfs():
    assert dbfs(32768.0 ** 2) == pytest.approx(0.0)
    assert dbfs(0.0) == -120.0
    assert dbfs((32768 / 10) ** 2) == pytest.approx(-20.0)


def test_voice_share_and_level():
    # 1 s window of 10 ms chunks at 16 kHz: 0.3 s of a loud tone (-9 dBFS
    # sine), the rest silence: a voice share of 0.3.
    rate, n = 16000, 160
    t = np.arange(rate) / rate
    x = np.where(t < 0.3, 16384 * np.sin(2 * np.pi * 440 * t), 0.0)
    x = x.astype(np.int16)
    msgs = [chunk(x[k:k + n]) for k in range(0, rate, n)]
    stamps = [50.0 + k / rate for k in range(0, rate, n)]
    r = run(AudioLevel(), msgs, stamps, 50.0, 51.0)
    assert r.value == pytest.approx(0.3)
    assert r.diagnostics['unit'] == 'voiced share (0-1)'   # not '1'
    level = 10 * math.log10(0.3 * 16384 ** 2 / 2 / 32768 ** 2)
    assert r.diagnostics['level_dbfs'] == pytest.approx(level, abs=0.05)
    r = run(AudioLevel(measure='level'), msgs, stamps, 50.0, 51.0)
    assert r.value == pytest.approx(level, abs=0.05)


def test_audio_past_the_window_end_and_gaps():
    loud = np.full(1600, 10000, np.int16)
    # A 0.1 s chunk whose last 0.06 s lie past the end: only 0.04 s (two
    # 20 ms blocks) count.
    r = run(AudioLevel(), [chunk(loud)], [0.96], 0.0, 1.0)
    assert r.value == pytest.approx(0.04)
    assert r.diagnostics['blocks'] == 2
    # Two chunks with a gap between them: counted, partial block dropped.
    r = run(AudioLevel(block=0.02), [chunk(loud[:400]), chunk(loud[:320])],
            [0.0, 0.5], 0.0, 1.0)
    assert r.diagnostics['gaps'] == 1
    assert r.value == pytest.approx(0.02 + 0.02)


def test_stereo_chunk():
    x = np.tile([[10000, -10000]], (320, 1))
    r = run(AudioLevel(), [chunk(x, channels=2)], [0.0], 0.0, 1.0)
    assert r.value == pytest.approx(0.02)


@pytest.mark.parametrize('msg, reason', [
    (chunk([]), 'empty'),
    (chunk([1, 2, 3], channels=2), 'wrong_length'),
    (chunk([1, 2], rate=0), 'bad_rate'),
    (chunk([1, 2], channels=0), 'bad_channels'),
])
def test_bad_audio_chunks_are_rejected(msg, reason):
    with pytest.raises(Rejected) as e:
        check_chunk(msg)
    assert e.value.reason == reason


def test_wav_and_chunks(tmp_path):
    import wave
    path = str(tmp_path / 'a.wav')
    with wave.open(path, 'wb') as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(8000)
        w.writeframes(struct.pack('<5h', 1, 2, 3, 4, 5))
    samples, rate = read_wav(path)
    assert rate == 8000 and samples[:, 0].tolist() == [1, 2, 3, 4, 5]
    c, t = chunk_at(samples, rate, 1, 3)
    assert c[:, 0].tolist() == [4, 5, 1] and t == 3 / 8000
    with pytest.raises(ValueError):
        read_wav(str(tmp_path / 'none.wav'))


# --- generic and loading -----------------------------------------------------

def test_header_count():
    p = load_processor('hri_sync.sensors.generic.HeaderCount',
                       {'msg_type': 'sensor_msgs/LaserScan'})
    assert p.msg_type == 'sensor_msgs/LaserScan' and p.topic == 'input'
    msgs = [NS(header=NS(stamp=stamp(3.5)))] * 5
    r = run(p, msgs, [1, 1.2, 1.4, 1.6, 1.8], 1.0, 2.0)
    assert (r.value, r.frames_used, r.diagnostics['rate']) == (5.0, 5, 5.0)
    assert p.device_stamp(msgs[0]) == 3.5
    with pytest.raises(ValueError):
        load_processor('hri_sync.sensors.generic.HeaderCount', {})


@pytest.mark.parametrize('path, msg_type, topic', [
    ('hri_sync.sensors.image.ImageMotion', 'sensor_msgs/Image', 'image'),
    ('hri_sync.sensors.imu.ImuActivity', 'sensor_msgs/Imu', 'imu'),
    ('hri_sync.sensors.joint_state.JointSpeed', 'sensor_msgs/JointState',
     'joint_states'),
    ('hri_sync.sensors.audio.AudioLevel', 'hri_sync/AudioChunk', 'audio'),
])
def test_stock_processors_load_by_class_path(path, msg_type, topic):
    p = load_processor(path)
    assert (p.msg_type, p.topic) == (msg_type, topic)


# --- the DPM core: invalid samples counted by reason -------------------------

def test_data_process_counts_invalid_samples_by_reason():
    clock = NS(local_ref=0.0, offset=0.0, drift=0.0, uncertainty=1e-4)
    dp = DataProcess(ImuActivity, stamp_source='arrival')
    dp.set_clock(clock)
    dp.open(1, 100.0, 101.0)
    good = imu((0.0, 0.0, 9.8))
    for k in range(100):
        dp.on_sample(imu((math.nan, 0, 0)) if k % 10 == 0 else good,
                     100.0 + 0.01 * k)
    step = dp.on_sample(good, 101.0)
    (r,) = step.results
    assert r.frames == 90 and r.frames_rejected == 10
    assert r.diagnostics['invalid_not_finite'] == 10
    assert r.diagnostics['invalid_total'] == 10
    assert 'linear_acceleration' in r.diagnostics['invalid_example']
    assert dp.counts['not_finite'] == 10
