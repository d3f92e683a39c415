"""The generated default track: size, tempo metadata, beats in the audio."""
import json
import os
import wave

import numpy as np
import pytest

from hri_sync.robot.music import TrackInfo, load_track_info, play_span

ROOT = os.path.join(os.path.dirname(__file__), '..', '..')
TRACK = os.path.join(ROOT, 'data', 'music', 'dj_rob_120bpm.wav')


def test_default_track_small_and_described():
    assert os.path.getsize(TRACK) < 2 * 1024 * 1024
    info = load_track_info(TRACK)
    assert info.bpm == 120.0 and info.first_beat == 0.0
    assert info.duration >= 60.0
    with wave.open(TRACK) as w:
        assert w.getnchannels() == 1
        assert w.getnframes() / w.getframerate() == pytest.approx(
            info.duration, abs=1e-3)
    with open(TRACK[:-4] + '.json') as f:
        beats = json.load(f)['beats']
    assert beats == pytest.approx([t for t, _ in info.beat_times(
        0.0, info.duration)])


def test_kicks_fall_on_the_listed_beats():
    info = load_track_info(TRACK)
    with wave.open(TRACK) as w:
        rate = w.getframerate()
        x = np.frombuffer(w.readframes(w.getnframes()), np.uint8)
    x = x.astype(float) - 128.0
    win = int(0.03 * rate)

    def energy(t):
        i = int(round(t * rate))
        return float(np.sum(x[i:i + win] ** 2))
    on = [energy(t) for t, _ in info.beat_times(0.0, info.duration - 0.1)]
    # a quarter beat later the kick has not decayed yet but no new one
    # starts; three eighths later (between hat and next beat) it is quiet
    off = [energy(t + 0.375 * info.beat_period)
           for t, _ in info.beat_times(0.0, info.duration - 0.1)]
    assert np.median(on) > 5 * np.median(off)
    assert min(on) > np.median(off)


def test_beats_loop_past_the_end():
    info = TrackInfo('x.wav', bpm=120.0, first_beat=0.25, duration=4.0)
    beats = info.beat_times(3.0, 9.0)
    assert [t for t, _ in beats] == pytest.approx(
        [3.25, 3.75, 4.25, 4.75, 5.25, 5.75, 6.25, 6.75, 7.25, 7.75, 8.25,
         8.75])
    assert [k for _, k in beats][:4] == [6, 7, 0, 1]


def test_window_beats_on_the_global_clock():
    info = TrackInfo('x.wav', bpm=120.0, first_beat=0.25, duration=4.0,
                     beats_per_bar=4)
    beats = info.window_beats(100.0, 105.0)
    assert [i for i, _, _ in beats] == list(range(10))
    assert [t for _, t, _ in beats] == pytest.approx(
        [100.25 + 0.5 * i for i in range(10)])
    # the loop restarts the bar at 4 s
    assert [b for _, _, b in beats] == [0, 1, 2, 3, 0, 1, 2, 3, 0, 1]


def test_play_span_loops_a_short_track():
    assert play_span(5.0, 64.0) == (0, 5000)
    assert play_span(64.0, 64.0) == (0, 64000)
    assert play_span(64.001, 64.0) == (1, 64001)
    assert play_span(130.0, 64.0) == (2, 130000)


def test_missing_or_bad_track_is_a_clear_error(tmp_path):
    with pytest.raises(ValueError, match='does not exist'):
        load_track_info(str(tmp_path / 'none.wav'))
    wav = tmp_path / 'a.wav'
    wav.write_bytes(b'RIFF')
    with pytest.raises(ValueError, match='unreadable'):
        load_track_info(str(wav))
    (tmp_path / 'a.json').write_text('{"bpm": -1, "first_beat": 0, '
                                     '"duration": 3}')
    with pytest.raises(ValueError, match='bad values'):
        load_track_info(str(wav))
