"""A tracker's frames in a window: expected, published, skipped apart."""
import math
from types import SimpleNamespace as NS

from hri_sync.clock.model import ClockModel
from hri_sync.dance_off.expressiveness import SkeletonExpressiveness
from hri_sync.dance_off.joints import NUM_JOINTS
from hri_sync.dance_off.sensor_frames import SensorFrames
from hri_sync.data_process.dpm import DataProcess
from hri_sync.data_process.processors import Frame

RATE = 30.0


def tracker_stream(n, untracked=(), stall=(), users=1, first=1):
    """(device s, frame index, skipped so far) of each skeleton a tracker
    publishes from ``n`` sensor frames: none for the ``untracked`` frames
    (processed, not published) or the ``stall`` frames (never processed,
    counted as skipped), ``users`` skeletons for each other frame."""
    out, skipped = [], 0
    for k in range(n):
        if k in stall:
            skipped += 1
            continue
        if k in untracked:
            continue
        out += [(10.0 + k / RATE, first + k, skipped)] * users
    return out


def count(stream, duration):
    frames = SensorFrames()
    for device, index, skipped in stream:
        frames.add(device, index, skipped)
    return frames.summary(duration)


def test_a_stall_is_counted_apart_from_untracked_frames():
    s = count(tracker_stream(300, untracked=range(0, 15),
                             stall=range(100, 130), users=2), 10.0)
    assert s['frames_expected'] == 300
    assert s['frames_published'] == 255
    assert s['frames_skipped'] == 30
    assert s['frames_unpublished'] == 15
    assert math.isclose(s['sensor_rate'], RATE)


def test_a_tracker_that_keeps_up_skips_nothing():
    s = count(tracker_stream(300), 10.0)
    assert (s['frames_expected'], s['frames_published'], s['frames_skipped'],
            s['frames_unpublished']) == (300, 300, 0, 0)


def test_every_other_frame_skipped_keeps_the_sensors_rate():
    # A tracker at half the sensor's rate: the stamps' spacing says 15 Hz,
    # the frame indices 30.
    s = count(tracker_stream(300, stall=range(1, 300, 2)), 10.0)
    assert s['frames_expected'] == 300
    assert s['frames_published'] == 150
    assert s['frames_skipped'] == 149      # the last one is after the last
    assert s['frames_unpublished'] == 1    # published: at the window's edge


def test_skips_before_the_first_frame_of_the_window_are_not_its_own():
    stream = [(d, i, k + 7) for d, i, k in tracker_stream(300,
                                                          stall=[50])]
    assert count(stream, 10.0)['frames_skipped'] == 1


def test_a_sensor_reopened_or_a_tracker_restarted_starts_over():
    before = tracker_stream(150, stall=[20, 21])        # skipped 2
    after = [(d + 5.0, i, k) for d, i, k in tracker_stream(150,
                                                          stall=[40])]
    s = count(before + after, 10.0)
    assert s['frames_published'] == 297
    assert s['frames_skipped'] == 3
    assert s['frames_expected'] == 300


def test_a_count_that_grew_more_than_the_frames_between_is_capped():
    # The count jumps by 200 between frames 100 and 101 (the tracker
    # counted frames of a stream the sensor switched from): none of them
    # lies between two published frames of this window.
    stream = [(d, i, k + (200 if i > 100 else 0))
              for d, i, k in tracker_stream(180, stall=[150])]
    s = count(stream, 6.0)
    assert s['frames_skipped'] == 1
    assert s['frames_published'] + s['frames_skipped'] <= \
        s['frames_expected']


def test_unknown_indices_count_nothing():
    s = count([(10.0, 0, 0), (10.1, 0, 5)], 10.0)
    assert s['frames_published'] == 0 and s['frames_skipped'] == 0
    assert math.isnan(s['frames_expected'])
    assert math.isnan(s['frames_unpublished'])
    s = count([(10.0, 4, 0)], 10.0)
    assert s['frames_published'] == 1 and math.isnan(s['sensor_rate'])


def skeleton(device, index, skipped):
    return NS(positions=[NS(x=0.0, y=0.0, z=2.0)] * NUM_JOINTS,
              confidence=[1.0] * NUM_JOINTS, user_id=1, device_stamp=device,
              frame_index=index, frames_skipped=skipped)


def test_the_window_result_says_what_the_tracker_skipped():
    # Through the DPM: a tracker that loses its person for 0.5 s (15
    # frames) and then stalls 1 s (30 frames) inside a 6 s window; its
    # result (partial: 1.5 s uncovered) counts both gaps as frames the
    # stamps miss (frames_dropped), and, told apart by the tracker, the
    # stall's as frames it skipped.
    local0, offset = 1000.0, 5.0
    d = DataProcess(SkeletonExpressiveness, stamp_source='device')
    d.set_clock(ClockModel(local0, offset, 0.0, 50e-6))
    start = local0 + offset + 2.0
    d.open(1, start, start + 6.0)
    got = []
    for device, index, skipped in tracker_stream(300, untracked=range(120,
                                                                       135),
                                                 stall=range(150, 180)):
        arrival = local0 + (device - 10.0) + 0.004
        got += d.on_sample(skeleton(device, index, skipped), arrival).results
    (r,) = got
    assert r.status == 'partial' and math.isclose(r.coverage, 0.75,
                                                   abs_tol=0.02)
    assert r.diagnostics['frames_expected'] == 180
    assert r.diagnostics['frames_skipped'] == 30
    assert r.diagnostics['frames_unpublished'] == 15
    assert r.diagnostics['frames_published'] == r.frames == 135
    assert r.frames_dropped == 45


def test_a_recording_read_back_scores_its_tracker_frames():
    # verify_decisions reads a bag with rosbags, whose times are (sec,
    # nanosec): a tracker's frames (frame_index > 0) are scored, not
    # counted as malformed.
    def frame(k):
        msg = skeleton(NS(sec=10 + k // 30, nanosec=(k % 30) * 33333333),
                       k + 1, 0)
        msg.positions = [NS(x=0.01 * k, y=0.0, z=2.0)] * NUM_JOINTS
        return Frame(100.0 + k / 30.0, msg)
    res = SkeletonExpressiveness().process([frame(k) for k in range(30)],
                                           100.0, 101.0)
    assert res.frames_used == 30 and res.frames_rejected == 0
    assert res.value > 0


def test_frames_out_of_index_order_are_not_a_restart():
    # A starved tracker's frames in stamp order, where the DPM's device
    # clock map moved down between two: after a stall (frames 100-101
    # skipped), frame 102 comes before frame 99.  Frame 99 is published,
    # not a reopened sensor whose count of skipped frames since it started
    # (40) would be the window's.
    stream = [(d, i, k + 40) for d, i, k in tracker_stream(
        180, stall=[99, 100])]
    at = next(n for n, (_, i, _) in enumerate(stream) if i == 99)
    stream[at], stream[at + 1] = stream[at + 1], stream[at]
    s = count(stream, 6.0)
    assert s['frames_published'] == 178
    assert s['frames_skipped'] == 2
    assert s['frames_published'] + s['frames_skipped'] <= \
        s['frames_expected']


def test_a_late_frame_stamped_past_the_later_ones_is_not_a_restart():
    # As above, with the device clock map moved up: frame 99 comes after
    # frame 102 and is stamped after it too.  Taken for a new stretch, the
    # frames after it would count the stall's frames again (a starved CI
    # run: 348 skipped of 180 expected).
    stream = [(d, i, k + 40) for d, i, k in tracker_stream(
        180, stall=[99, 100])]
    at = next(n for n, (_, i, _) in enumerate(stream) if i == 99)
    late = stream.pop(at)
    stream.insert(at + 1, (stream[at][0] + 0.01, late[1], late[2]))
    s = count(stream, 6.0)
    assert s['frames_published'] == 178
    assert s['frames_skipped'] == 2
    assert s['frames_expected'] == 180


def test_a_restart_that_gives_a_skipped_frames_index_again_starts_over():
    # The tracker restarted (its count back to 0) and its sensor's first
    # frame has the index of one the stretch skipped: a new stretch, not a
    # late frame (its count is below those of the frames around it).
    before = [(d, i, k + 5) for d, i, k in tracker_stream(150,
                                                          stall=[20])]
    after = [(d + 5.0, i + 20, k) for d, i, k in tracker_stream(100)]
    s = count(before + after, 10.0)
    assert s['frames_published'] == 249
    assert s['frames_skipped'] == 1
