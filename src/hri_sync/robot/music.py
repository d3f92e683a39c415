"""Music track metadata and beat times, pure Python.

A track is an audio file with a JSON sidecar of the same stem
(``data/music/dj_rob_120bpm.wav`` + ``dj_rob_120bpm.json``) written by
``scripts/make_music.py``: ``bpm``, ``first_beat`` (s), ``duration`` (s),
``sample_rate``, ``beats_per_bar`` and ``beats`` (all beat times, s).
The player loops the track when a window is longer than it, so beats are
given on the looped time line.
"""
import json
import math
import os
from dataclasses import dataclass


@dataclass(frozen=True)
class TrackInfo:
    """What the player and the dance need to know about a track."""

    path: str
    bpm: float
    first_beat: float
    duration: float
    beats_per_bar: int = 4

    @property
    def beat_period(self):
        return 60.0 / self.bpm

    def beat_times(self, start, end):
        """Beat times (s from the track start, looping) in ``[start, end)``,
        as (time, beat index within the loop) pairs."""
        period = self.beat_period
        per_loop = int(round((self.duration - self.first_beat) / period))
        if per_loop < 1:
            return []
        out = []
        loop = max(0, int(math.floor((start - self.first_beat)
                                     / self.duration)))
        while True:
            base = loop * self.duration + self.first_beat
            if base >= end:
                return out
            for k in range(per_loop):
                t = base + k * period
                if t >= end:
                    return out
                if t >= start:
                    out.append((t, k))
            loop += 1

    def window_beats(self, start, end):
        """The beats of the track played from global ``start`` until
        ``end``: (index from 0, global time, beat within the bar) each."""
        return [(index, start + t, k % self.beats_per_bar) for index, (t, k)
                in enumerate(self.beat_times(0.0, end - start))]


def play_span(duration, length):
    """How to play a track of ``length`` s for ``duration`` s: (extra
    loops, play time in whole ms), pygame's ``Sound.play`` arguments."""
    loops = max(0, math.ceil(duration / length) - 1)
    return loops, int(round(duration * 1000))


def sidecar_path(audio_path):
    """The JSON sidecar of ``audio_path``."""
    return os.path.splitext(audio_path)[0] + '.json'


def load_track_info(audio_path):
    """Read the track's sidecar; raises ValueError with the reason when the
    audio file or the sidecar is missing or malformed."""
    if not os.path.isfile(audio_path):
        raise ValueError('audio file %s does not exist (generate the default '
                         'track with scripts/make_music.py)' % audio_path)
    meta = sidecar_path(audio_path)
    try:
        with open(meta) as f:
            data = json.load(f)
        info = TrackInfo(path=audio_path, bpm=float(data['bpm']),
                         first_beat=float(data['first_beat']),
                         duration=float(data['duration']),
                         beats_per_bar=int(data.get('beats_per_bar', 4)))
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise ValueError('track metadata %s unreadable: %s' % (meta, e))
    if not (info.bpm > 0 and info.duration > 0 and info.first_beat >= 0
            and math.isfinite(info.bpm + info.duration + info.first_beat)):
        raise ValueError('track metadata %s has bad values: bpm %r, '
                         'duration %r, first_beat %r'
                         % (meta, info.bpm, info.duration, info.first_beat))
    return info
