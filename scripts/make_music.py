#!/usr/bin/env python3
"""Generate DJ Rob's default track: a drum and synth loop at a known tempo.

Writes ``data/music/dj_rob_120bpm.wav`` (22.05 kHz mono, 8-bit PCM with
dither so 64 s stay under 2 MB, and needs no encoder) and its sidecar
``dj_rob_120bpm.json`` (tempo, first beat, duration, every beat time) that
``hri_sync.robot.music`` reads.  Deterministic: running it again gives the same
bytes.  Needs only numpy.

    /usr/bin/python3 scripts/make_music.py [--out DIR] [--bpm 120] [--bars 32]
"""
import argparse
import json
import os
import wave

import numpy as np

RATE = 22050
BEATS_PER_BAR = 4
# A minor - F - C - G, one chord a bar: (root Hz, chord tones as semitones).
PROGRESSION = [(110.00, (0, 3, 7)), (87.31, (0, 4, 7)),
               (130.81, (0, 4, 7)), (98.00, (0, 4, 7))]


def envelope(n, decay_s, attack_s=0.002):
    """Exponential decay with a short linear attack, n samples long."""
    t = np.arange(n) / RATE
    env = np.exp(-t / decay_s)
    attack = max(1, int(attack_s * RATE))
    env[:attack] *= np.linspace(0.0, 1.0, attack)
    return env


def kick(n):
    t = np.arange(n) / RATE
    freq = 45.0 + 110.0 * np.exp(-t / 0.04)
    phase = 2 * np.pi * np.cumsum(freq) / RATE
    return np.sin(phase) * envelope(n, 0.18)


def snare(n, rng):
    t = np.arange(n) / RATE
    noise = rng.uniform(-1, 1, n)
    noise = np.diff(noise, prepend=0.0) * 0.6       # brighter
    tone = np.sin(2 * np.pi * 185.0 * t)
    return (0.7 * noise * envelope(n, 0.07) + 0.4 * tone * envelope(n, 0.05))


def hihat(n, rng):
    noise = np.diff(rng.uniform(-1, 1, n), prepend=0.0)
    return noise * envelope(n, 0.025, 0.0005)


def lowpass(x, cutoff):
    """One-pole low-pass filter."""
    a = np.exp(-2 * np.pi * cutoff / RATE)
    y = np.empty_like(x)
    acc = 0.0
    for i, v in enumerate(x):
        acc = (1 - a) * v + a * acc
        y[i] = acc
    return y


def saw(freq, n):
    t = np.arange(n) / RATE
    return 2.0 * ((freq * t) % 1.0) - 1.0


def square(freq, n):
    t = np.arange(n) / RATE
    return np.sign(np.sin(2 * np.pi * freq * t))


def render(bpm, bars, seed=4):
    """The whole track as float samples in [-1, 1]."""
    rng = np.random.default_rng(seed)
    beat = 60.0 / bpm
    n_total = int(round(bars * BEATS_PER_BAR * beat * RATE))
    out = np.zeros(n_total + RATE)        # tail room, cut below

    def add(sound, at_s, gain):
        i = int(round(at_s * RATE))
        out[i:i + len(sound)] += gain * sound

    kick_s = kick(int(0.35 * RATE))
    hat_s = hihat(int(0.08 * RATE), rng)
    snare_s = snare(int(0.2 * RATE), rng)
    eighth = beat / 2
    for bar in range(bars):
        t_bar = bar * BEATS_PER_BAR * beat
        root, tones = PROGRESSION[bar % len(PROGRESSION)]
        section = bar // 4                # a new layer every 4 bars
        for b in range(BEATS_PER_BAR):
            t = t_bar + b * beat
            add(kick_s, t, 0.9)
            if section >= 1 and b % 2 == 1:
                add(snare_s, t, 0.5)
            if bar < bars - 1 or b < 3:
                add(hat_s, t + eighth, 0.35)
                add(hat_s, t, 0.15)
        if section >= 2:                  # bass: root on every eighth note
            n = int(eighth * RATE * 0.9)
            low = lowpass(saw(root / 2, n), 600.0) * envelope(n, 0.15)
            octave = lowpass(saw(root, n), 600.0) * envelope(n, 0.15)
            for k in range(BEATS_PER_BAR * 2):
                add(octave if k % 4 == 3 else low, t_bar + k * eighth, 0.45)
        if section >= 3:                  # arpeggio in sixteenths
            n = int(eighth / 2 * RATE * 0.8)
            for k in range(BEATS_PER_BAR * 4):
                semis = tones[k % len(tones)] + (12 if k % 8 >= 4 else 0)
                f = root * 4 * 2 ** (semis / 12.0)
                add(square(f, n) * envelope(n, 0.06), t_bar + k * eighth / 2,
                    0.12)
        if section >= 4:                  # pad: the chord, sustained
            n = int(BEATS_PER_BAR * beat * RATE)
            pad = sum(saw(root * 2 * 2 ** (s / 12.0), n) for s in tones)
            swell = np.minimum(1.0, np.arange(n) / (0.3 * RATE))
            add(lowpass(pad, 1200.0) * swell, t_bar, 0.06)
    out = out[:n_total]
    fade = int(0.01 * RATE)              # no click at the loop point
    out[-fade:] *= np.linspace(1.0, 0.0, fade)
    return out / np.max(np.abs(out)) * 0.89, rng


def write_wav8(path, samples, rng):
    """Unsigned 8-bit mono PCM with triangular dither."""
    dither = (rng.uniform(-0.5, 0.5, len(samples))
              + rng.uniform(-0.5, 0.5, len(samples)))
    q = np.clip(np.round(samples * 127.0 + dither) + 128, 0, 255)
    with wave.open(path, 'wb') as w:
        w.setnchannels(1)
        w.setsampwidth(1)
        w.setframerate(RATE)
        w.writeframes(q.astype(np.uint8).tobytes())


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    parser = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    parser.add_argument('--out', default=os.path.normpath(
        os.path.join(here, '..', 'data', 'music')))
    parser.add_argument('--bpm', type=float, default=120.0)
    parser.add_argument('--bars', type=int, default=32)
    args = parser.parse_args()
    os.makedirs(args.out, exist_ok=True)
    stem = 'dj_rob_%dbpm' % round(args.bpm)
    samples, rng = render(args.bpm, args.bars)
    wav = os.path.join(args.out, stem + '.wav')
    write_wav8(wav, samples, rng)
    duration = len(samples) / RATE
    beat = 60.0 / args.bpm
    n_beats = args.bars * BEATS_PER_BAR
    meta = {
        'file': stem + '.wav',
        'bpm': args.bpm,
        'beats_per_bar': BEATS_PER_BAR,
        'first_beat': 0.0,
        'duration': duration,
        'sample_rate': RATE,
        'generator': 'scripts/make_music.py',
        'beats': [round(k * beat, 6) for k in range(n_beats)],
    }
    with open(os.path.join(args.out, stem + '.json'), 'w') as f:
        json.dump(meta, f, indent=1)
        f.write('\n')
    print('%s: %.1f s, %.0f BPM, %d beats, %d bytes'
          % (wav, duration, args.bpm, n_beats, os.path.getsize(wav)))


if __name__ == '__main__':
    main()
