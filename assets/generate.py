#!/usr/bin/env python3
"""Synthesise every EnergyBall sound from first principles: numpy in, 16-bit WAV out.

No recorded or downloaded media: each sound is built from oscillators, seeded noise,
envelopes and filters written below, so the files under ``assets/`` are ours (CC0) and
can be rebuilt bit for bit.

    python assets/generate.py [--out DIR] [--only NAME ...]   write the WAVs (atomically)
    python assets/generate.py --check                          compare the files with a fresh render
                                                               (sha256); exit 1 if any differ

Format: 22050 Hz, mono, 16-bit PCM.  One-shots start and end at silence; the loops
(``charge_*``, ``music``) are built on a circular time axis (every oscillator completes
whole cycles, every tail that runs past the end wraps round to the start, every filter
is a circular FFT filter), so the last sample joins the first without a click.

Determinism: each sound draws its noise from its own ``numpy.random.default_rng(seed)``
(uniform ``random()`` only, whose stream numpy keeps stable), so a render does not depend
on which other sounds are made or in what order.  ``--check`` compares bytes, so a numpy
or CPU whose float rounding differs in the last bit could in principle flip an LSB; the
sound would be the same to any ear, and regenerating is the fix.
"""

from __future__ import annotations

import argparse
import hashlib
import io
import json
import os
import sys
import tempfile
import wave
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

RATE = 22050  # Hz
TAU = 2.0 * np.pi
NYQUIST = RATE / 2.0
HERE = Path(__file__).resolve().parent


# --------------------------------------------------------------------------------------
# Building blocks: time, noise, oscillators, envelopes, filters
# --------------------------------------------------------------------------------------

def samples(duration_s: float) -> int:
    """Number of samples in ``duration_s`` seconds."""
    return int(round(duration_s * RATE))


def clock(n: int) -> np.ndarray:
    """Sample times in seconds for ``n`` samples."""
    return np.arange(n) / RATE


def noise(n: int, seed: int) -> np.ndarray:
    """White noise, uniform in [-1, 1), from its own seeded generator."""
    return np.random.default_rng(seed).random(n) * 2.0 - 1.0


def phase_of(freq_hz: np.ndarray) -> np.ndarray:
    """Running phase (radians) of an oscillator whose frequency is given per sample."""
    freq_hz = np.asarray(freq_hz, float)
    if freq_hz.ndim != 1:
        raise ValueError("phase_of needs one frequency per sample")
    return TAU * np.cumsum(freq_hz) / RATE


def harmonics(phase: np.ndarray, top_hz: float, weight: Callable[[int], float], limit: int = 200) -> np.ndarray:
    """Band-limited additive tone: sum of weight(k) sin(k phase), only partials below Nyquist.

    ``top_hz`` is the highest fundamental the phase reaches, so no partial ever aliases.
    """
    out = np.zeros_like(phase)
    for k in range(1, limit + 1):
        if k * top_hz >= 0.95 * NYQUIST:
            break
        w = weight(k)
        if w:
            out += w * np.sin(k * phase)
    return out


def saw(phase: np.ndarray, top_hz: float, tilt: float = 1.0, limit: int = 200) -> np.ndarray:
    """Band-limited sawtooth; ``tilt`` > 1 darkens it (partials fall as 1/k**tilt)."""
    return harmonics(phase, top_hz, lambda k: 1.0 / k ** tilt, limit)


def square(phase: np.ndarray, top_hz: float, tilt: float = 1.0, limit: int = 200) -> np.ndarray:
    """Band-limited square (odd partials only)."""
    return harmonics(phase, top_hz, lambda k: (k % 2) / k ** tilt, limit)


def wavetable(partials: dict[int, float], size: int = 4096) -> np.ndarray:
    """One cycle of a periodic wave from its partial amplitudes (for cheap steady tones)."""
    x = np.arange(size) / size
    return sum(a * np.sin(TAU * k * x) for k, a in partials.items())


def play_table(table: np.ndarray, phase: np.ndarray) -> np.ndarray:
    """Read a wavetable at the given running phase, with linear interpolation."""
    pos = (phase / TAU % 1.0) * len(table)
    i = pos.astype(int) % len(table)
    frac = pos - np.floor(pos)
    return table[i] * (1.0 - frac) + table[(i + 1) % len(table)] * frac


def decay(n: int, tau_s: float) -> np.ndarray:
    """Exponential decay exp(-t / tau)."""
    return np.exp(-clock(n) / tau_s)


def ramp(n: int, attack_s: float, release_s: float) -> np.ndarray:
    """Raised-cosine fade in over ``attack_s`` and out over ``release_s`` (1 in between)."""
    env = np.ones(n)
    rise, fall = min(samples(attack_s), n), min(samples(release_s), n)
    if rise:
        env[:rise] *= 0.5 - 0.5 * np.cos(np.pi * np.arange(rise) / rise)
    if fall:
        env[n - fall:] *= 0.5 + 0.5 * np.cos(np.pi * np.arange(1, fall + 1) / fall)
    return env


def glide(n: int, start_hz: float, end_hz: float, curve: float = 1.0) -> np.ndarray:
    """Exponential (musical) frequency glide; ``curve`` > 1 lingers near the start."""
    u = np.linspace(0.0, 1.0, n) ** curve
    return start_hz * (end_hz / start_hz) ** u


def fft_filter(x: np.ndarray, gain: Callable[[np.ndarray], np.ndarray], circular: bool = False) -> np.ndarray:
    """Zero-phase filter by a gain curve over frequency (Hz).

    ``circular`` treats the signal as one period of a loop (no padding), which keeps a
    loop seamless; otherwise the signal is padded so that nothing wraps round.
    """
    n = len(x)
    size = n if circular else 1 << int(np.ceil(np.log2(2 * n)))
    spectrum = np.fft.rfft(x, size)
    freqs = np.fft.rfftfreq(size, 1.0 / RATE)
    return np.fft.irfft(spectrum * gain(freqs), size)[:n]


def stft_filter(x: np.ndarray, gain: Callable[[np.ndarray, np.ndarray], np.ndarray],
                frame: int = 1024, hop: int = 256) -> np.ndarray:
    """Time-varying filter: gain(t[:, None], f[None, :]) applied frame by frame (Hann, overlap-add)."""
    n = len(x)
    padded = np.concatenate([np.zeros(frame), x, np.zeros(frame)])
    starts = np.arange(0, len(padded) - frame + 1, hop)
    window = 0.5 - 0.5 * np.cos(TAU * np.arange(frame) / frame)  # periodic Hann: sums to frame/(2 hop)
    frames = padded[starts[:, None] + np.arange(frame)] * window
    freqs = np.fft.rfftfreq(frame, 1.0 / RATE)
    centre_t = (starts + frame / 2 - frame) / RATE
    filtered = np.fft.irfft(np.fft.rfft(frames, axis=1) * gain(centre_t[:, None], freqs[None, :]), frame, axis=1)
    out = np.zeros(len(padded))
    for start, chunk in zip(starts, filtered):
        out[start:start + frame] += chunk
    return out[frame:frame + n] / (frame / (2 * hop))


def band(freqs: np.ndarray, centre_hz, width_octaves: float) -> np.ndarray:
    """Band-pass gain: a Gaussian bump on a log-frequency axis (0 at DC)."""
    f = np.maximum(freqs, 1e-3)
    return np.exp(-0.5 * (np.log2(f / centre_hz) / width_octaves) ** 2) * (freqs > 0)


def lowpass(freqs: np.ndarray, cutoff_hz, order: int = 2) -> np.ndarray:
    """Butterworth-shaped low-pass magnitude."""
    return 1.0 / np.sqrt(1.0 + (freqs / cutoff_hz) ** (2 * order))


def highpass(freqs: np.ndarray, cutoff_hz, order: int = 2) -> np.ndarray:
    """Butterworth-shaped high-pass magnitude (0 at DC)."""
    f = np.maximum(freqs, 1e-3)
    return 1.0 / np.sqrt(1.0 + (cutoff_hz / f) ** (2 * order)) * (freqs > 0)


def formants(freqs: np.ndarray, peaks: list[tuple[float, float, float]]) -> np.ndarray:
    """Vocal-tract gain: a sum of resonances (centre Hz, bandwidth Hz, level)."""
    return sum(level / (1.0 + ((freqs - f) / (0.5 * bw)) ** 2) for f, bw, level in peaks)


def mix_in(buffer: np.ndarray, start: int, signal: np.ndarray, wrap: bool = False) -> None:
    """Add ``signal`` into ``buffer`` at ``start``; past the end it wraps (loops) or is cut."""
    n = len(buffer)
    if wrap:
        start %= n
    while len(signal) and start < n:
        room = n - start
        buffer[start:start + min(room, len(signal))] += signal[:room]
        signal = signal[room:] if wrap else signal[:0]
        start = 0


def midi_hz(note: float) -> float:
    """Equal-tempered frequency of a MIDI note number (69 = A4 = 440 Hz)."""
    return 440.0 * 2.0 ** ((note - 69.0) / 12.0)


def smooth_random(n: int, seed: int, rate_hz: float) -> np.ndarray:
    """Slow random wander in about [-1, 1] (noise low-passed at ``rate_hz``)."""
    wander = fft_filter(noise(n, seed), lambda f: lowpass(f, rate_hz, 2))
    return wander / (np.max(np.abs(wander)) + 1e-12)


def crackles(n: int, count: int, seed: int, wrap: bool = False) -> np.ndarray:
    """Sparse electric crackle: ``count`` tiny high-passed noise bursts at seeded places."""
    rng = np.random.default_rng(seed)
    out = np.zeros(n)
    burst = samples(0.006)
    raw = fft_filter(noise(burst * count, seed + 1), lambda f: highpass(f, 2500.0, 2))
    for i in range(count):
        place = int(rng.random() * n)
        level = 0.3 + 0.7 * rng.random()
        mix_in(out, place, raw[i * burst:(i + 1) * burst] * decay(burst, 0.0015) * level, wrap)
    return out


# --------------------------------------------------------------------------------------
# The sounds
# --------------------------------------------------------------------------------------

def make_launch() -> np.ndarray:
    """Rising whoosh: a noise band sweeping up 300 Hz -> 4 kHz, plus a tone gliding up two octaves."""
    n = samples(0.7)
    t = clock(n)
    centre = lambda tt: 300.0 * (4000.0 / 300.0) ** np.clip(tt / 0.55, 0.0, 1.0)
    whoosh = stft_filter(noise(n, 101), lambda tt, f: band(f, centre(tt), 0.45))
    swell = np.clip(t / 0.35, 0.0, 1.0) ** 1.5 * np.exp(-np.maximum(t - 0.35, 0.0) / 0.09)
    freq = glide(n, 220.0, 880.0, curve=0.7)
    ph = phase_of(freq)
    tone = np.sin(ph) + 0.3 * np.sin(2 * ph) + 0.12 * np.sin(3 * ph + 0.4 * np.sin(ph))
    tone_env = np.clip(t / 0.05, 0.0, 1.0) * np.exp(-np.maximum(t - 0.25, 0.0) / 0.12)
    return 1.6 * whoosh * swell + 0.35 * tone * tone_env


def make_charge(level: int) -> np.ndarray:
    """One-second seamless energy hum (level 1 low .. 3 high): harmonic drone, beating, shimmer, crackle.

    Every frequency is a whole number of hertz, so every partial completes whole cycles in
    the second and the loop joins itself exactly.
    """
    n = samples(1.0)
    t = clock(n)
    f0 = {1: 82, 2: 110, 3: 147}[level]
    tremolo_hz = {1: 6, 2: 9, 3: 13}[level]
    drone = sum((1.0 / k ** 1.2) * (np.sin(TAU * k * f0 * t) + 0.6 * np.sin(TAU * (k * f0 + k) * t))
                for k in range(1, 9))
    drone *= 1.0 - 0.28 * (0.5 + 0.5 * np.sin(TAU * tremolo_hz * t))
    shimmer = fft_filter(noise(n, 200 + level), lambda f: band(f, 1800.0 + 700.0 * level, 0.35), circular=True)
    shimmer *= 0.5 + 0.5 * np.sin(TAU * 2 * tremolo_hz * t) ** 2
    spark = crackles(n, {1: 6, 2: 12, 3: 22}[level], 210 + level, wrap=True)
    return 0.5 * drone + (0.9 + 0.4 * level) * shimmer + (0.25 + 0.15 * level) * spark


def make_hit() -> np.ndarray:
    """Punchy boom (sine dropping 140 -> 42 Hz, soft-clipped) with an electric zap on top."""
    n = samples(0.75)
    t = clock(n)
    boom = np.sin(phase_of(42.0 + 98.0 * np.exp(-t / 0.04))) * decay(n, 0.18)
    thump = fft_filter(noise(n, 301), lambda f: lowpass(f, 900.0, 2)) * decay(n, 0.012)
    zap_freq = glide(n, 1900.0, 260.0, curve=0.5)
    zap_ph = phase_of(zap_freq)
    zap = square(zap_ph, 1900.0, tilt=1.2) * (0.6 + 0.4 * np.sin(TAU * 55.0 * t)) * decay(n, 0.07)
    crack = fft_filter(noise(n, 302), lambda f: highpass(f, 3000.0, 2)) * decay(n, 0.02)
    body = np.tanh(2.2 * (boom + 1.5 * thump)) / np.tanh(2.2)
    return body + 0.32 * zap + 0.25 * crack


def make_miss() -> np.ndarray:
    """Soft fizzle: a noise band sinking 2.6 kHz -> 500 Hz and fading, with dying crackles."""
    n = samples(0.6)
    t = clock(n)
    centre = lambda tt: 2600.0 * (500.0 / 2600.0) ** np.clip(tt / 0.5, 0.0, 1.0)
    hiss = stft_filter(noise(n, 401), lambda tt, f: band(f, centre(tt), 0.6))
    env = np.clip(t / 0.03, 0.0, 1.0) * decay(n, 0.16)
    spark = crackles(n, 9, 402) * decay(n, 0.12)
    return hiss * env + 0.2 * spark


def make_wall() -> np.ndarray:
    """A ball bursting on a wall: a dull thud (sine dropping 110 -> 55 Hz) on a short knock of low noise,
    and a few sparks crackling off."""
    n = samples(0.4)
    t = clock(n)
    thud = np.sin(phase_of(55.0 + 55.0 * np.exp(-t / 0.025))) * decay(n, 0.07)
    knock = fft_filter(noise(n, 451), lambda f: band(f, 380.0, 1.2)) * decay(n, 0.018)
    knock /= np.max(np.abs(knock)) + 1e-12
    spark = crackles(n, 6, 452) * decay(n, 0.08)
    return np.tanh(1.8 * (thud + 0.8 * knock)) * ramp(n, 0.002, 0.05) + 0.25 * spark


VOWELS = {  # zombie vowels: formant (Hz, bandwidth Hz, level), set a little lower than a person's
    "oo": [(320.0, 90.0, 1.0), (720.0, 120.0, 0.5), (2200.0, 200.0, 0.12)],
    "aa": [(640.0, 110.0, 1.0), (1000.0, 130.0, 0.6), (2300.0, 220.0, 0.18)],
    "uh": [(520.0, 100.0, 1.0), (1050.0, 130.0, 0.45), (2250.0, 220.0, 0.14)],
}
GROANS = {  # variant: (seed, base pitch Hz, seconds, vowel path)
    1: (501, 84.0, 1.35, ("oo", "aa", "uh")),
    2: (502, 68.0, 1.65, ("uh", "aa", "oo")),
    3: (503, 98.0, 1.15, ("aa", "uh", "uh")),
}


def make_groan(variant: int) -> np.ndarray:
    """Zombie groan: a buzzy source with vibrato, jitter and a growling sub-octave, through moving formants."""
    seed, base, duration, path = GROANS[variant]
    n = samples(duration)
    t = clock(n)
    u = t / duration
    contour = 1.0 + 0.12 * np.sin(np.pi * np.minimum(u / 0.35, 1.0)) - 0.22 * u  # rise, then sag
    vibrato = 1.0 + 0.035 * np.sin(TAU * 5.3 * t + 1.3 * variant)
    jitter = 1.0 + 0.05 * smooth_random(n, seed, 9.0)
    freq = base * contour * vibrato * jitter
    ph = phase_of(freq)
    top = float(freq.max())
    rough = 1.0 + 0.35 * smooth_random(n, seed + 10, 35.0)  # vocal fry: uneven pulse strength
    source = saw(ph, top, tilt=0.9, limit=80) * rough + 0.5 * np.sin(0.5 * ph) + 0.25 * noise(n, seed + 20)
    spots = np.array([0.0, 0.5, 1.0])
    peaks = np.array([[p for p, _, _ in VOWELS[v]] for v in path])  # vowel x formant
    widths = np.array([[w for _, w, _ in VOWELS[v]] for v in path])
    levels = np.array([[a for _, _, a in VOWELS[v]] for v in path])

    def tract(tt, f):
        uu = np.clip(tt / duration, 0.0, 1.0)[..., 0]
        gain = np.zeros((len(uu), f.shape[-1]))
        for j in range(peaks.shape[1]):
            fc = np.interp(uu, spots, peaks[:, j])[:, None]
            bw = np.interp(uu, spots, widths[:, j])[:, None]
            lv = np.interp(uu, spots, levels[:, j])[:, None]
            gain += lv / (1.0 + ((f - fc) / (0.5 * bw)) ** 2)
        return gain * lowpass(f, 3200.0, 2)

    voice = stft_filter(source, tract)
    env = ramp(n, 0.18, 0.45) * (0.85 + 0.15 * np.sin(TAU * 1.7 * t))
    return np.tanh(1.5 * voice * env / (np.max(np.abs(voice)) + 1e-12))


def make_hurt() -> np.ndarray:
    """Player hurt: a heavy body thud with a short distorted crunch."""
    n = samples(0.5)
    t = clock(n)
    thud = np.sin(phase_of(48.0 + 70.0 * np.exp(-t / 0.03))) * decay(n, 0.11)
    knock = fft_filter(noise(n, 601), lambda f: lowpass(f, 450.0, 2)) * decay(n, 0.03)
    crunch_ph = phase_of(glide(n, 150.0, 95.0))
    crunch = fft_filter(square(crunch_ph, 150.0, tilt=0.8, limit=60),
                        lambda f: formants(f, VOWELS["uh"])) * ramp(n, 0.005, 0.0) * decay(n, 0.09)
    crunch /= np.max(np.abs(crunch)) + 1e-12
    return np.tanh(2.0 * (thud + 2.0 * knock)) + 0.45 * np.tanh(3.0 * crunch)


def make_wave() -> np.ndarray:
    """Gong for a new wave: inharmonic bell partials (each with a beating twin) decaying at their own rates."""
    n = samples(2.8)
    t = clock(n)
    base = 220.0  # A3, the dominant of the music's D minor; its hum partial sounds A2
    partials = [(0.5, 0.55), (1.0, 1.0), (1.183, 0.55), (1.506, 0.6), (2.0, 0.45), (2.514, 0.35),
                (2.662, 0.3), (3.011, 0.22), (4.166, 0.15), (5.433, 0.1)]
    ring = np.zeros(n)
    for i, (ratio, level) in enumerate(partials):
        f = base * ratio
        tau = 2.4 / ratio ** 0.75
        swell = 1.0 - 0.5 * np.exp(-t / (0.05 * (i + 1)))  # upper partials bloom slightly late
        ring += level * swell * decay(n, tau) * (np.sin(TAU * f * t + i) + 0.6 * np.sin(TAU * (f + 0.7 + 0.2 * i) * t))
    strike = fft_filter(noise(n, 701), lambda f: band(f, 1800.0, 0.9)) * decay(n, 0.012)
    return ring * ramp(n, 0.002, 0.0) + 1.5 * strike


def make_game_over() -> np.ndarray:
    """Descending tones A4, F4, D4, A3 -> a long low D3 with slow vibrato."""
    notes = [(69, 0.34), (65, 0.34), (62, 0.34), (57, 0.34), (50, 1.5)]
    n = samples(sum(d for _, d in notes) + 0.2)
    out = np.zeros(n)
    table = wavetable({k: (k % 2 or 0.3) / k ** 1.6 for k in range(1, 10)})  # hollow, soft square
    start = 0
    for i, (note, length) in enumerate(notes):
        m = samples(length + 0.25)
        tt = clock(m)
        last = i == len(notes) - 1
        f = midi_hz(note) * (1.0 + 0.012 * last * np.sin(TAU * 4.5 * tt) * np.clip(tt / 0.4, 0.0, 1.0))
        tone = play_table(table, phase_of(f)) + 0.5 * play_table(table, phase_of(f * 1.004))
        env = ramp(m, 0.01, 0.2) * (decay(m, 0.9) if last else decay(m, 0.35))
        mix_in(out, start, tone * env)
        start += samples(length)
    return out


def make_click() -> np.ndarray:
    """UI click: a 40 ms bright blip."""
    n = samples(0.04)
    t = clock(n)
    blip = (np.sin(TAU * 1800.0 * t) + 0.4 * np.sin(TAU * 3700.0 * t)) * decay(n, 0.006)
    tick = fft_filter(noise(n, 901), lambda f: highpass(f, 4000.0, 2)) * decay(n, 0.0015)
    return blip + 0.8 * tick


BPM = 100.0
BEAT = samples(60.0 / BPM)  # 13230 samples at 100 bpm
BAR = 4 * BEAT
EIGHTH = BEAT // 2
# (bars, bass root MIDI, pad chord MIDI) in D minor; 12 bars = 28.8 s; ends on A to lead back to Dm.
PROGRESSION = [
    (2, 38, (50, 53, 57, 62)),   # Dm
    (2, 34, (53, 58, 62, 65)),   # Bb
    (2, 43, (55, 58, 62, 67)),   # Gm
    (2, 33, (57, 61, 64, 69)),   # A
    (1, 38, (50, 53, 57, 62)),   # Dm
    (1, 39, (51, 55, 58, 63)),   # Eb (the flat second: darker)
    (1, 43, (55, 58, 62, 67)),   # Gm
    (1, 33, (57, 61, 64, 69)),   # A
]
BASS_STEPS = [0, 0, 12, 0, 0, 7, 12, 10]  # semitones over the root, one per eighth note


def bass_note(freq: float, length: int, accent: float) -> np.ndarray:
    """Bass: a band-limited saw whose brightness closes fast (a filter envelope), plus a sub sine."""
    t = clock(length)
    cutoff = 180.0 + 1300.0 * accent * np.exp(-t / 0.07)
    ph = TAU * freq * t
    tone = np.zeros(length)
    for k in range(1, 41):  # saw partials 1/k, each weighted by a 4th-order low-pass at the moving cutoff
        if k * freq >= 0.95 * NYQUIST:
            break
        tone += np.sin(k * ph) / k / np.sqrt(1.0 + (k * freq / cutoff) ** 4)
    return (tone + 0.6 * np.sin(ph)) * ramp(length, 0.004, 0.03)


def kick() -> np.ndarray:
    """Kick drum: a sine dropping 150 -> 45 Hz with a short click."""
    n = samples(0.45)
    t = clock(n)
    body = np.sin(phase_of(45.0 + 105.0 * np.exp(-t / 0.035))) * decay(n, 0.2)
    click = fft_filter(noise(n, 1001), lambda f: band(f, 3000.0, 1.0)) * decay(n, 0.003)
    return np.tanh(1.5 * body + click)


def snare() -> np.ndarray:
    """Snare: a noise band around 1.8 kHz with a 185 Hz body."""
    n = samples(0.3)
    t = clock(n)
    rattle = fft_filter(noise(n, 1002), lambda f: band(f, 1800.0, 1.3)) * decay(n, 0.09)
    body = np.sin(TAU * 185.0 * t) * decay(n, 0.04)
    return 2.5 * rattle + 0.6 * body


def hat(open_: bool) -> np.ndarray:
    """Hi-hat: high-passed noise, closed (short) or open (longer)."""
    n = samples(0.3 if open_ else 0.08)
    return fft_filter(noise(n, 1003 + open_), lambda f: highpass(f, 6500.0, 3)) * decay(n, 0.09 if open_ else 0.018)


def make_music() -> np.ndarray:
    """A dark 28.8 s loop at 100 bpm: saw bass in eighths, a detuned pad, kick/snare/hats.

    Built on a circular buffer: notes and drum tails that run past the end wrap round to the
    start and the final tone shaping is a circular FFT filter, so the loop is seamless.
    """
    bars = sum(b for b, _, _ in PROGRESSION)
    n = bars * BAR
    bass, pad, drums = np.zeros(n), np.zeros(n), np.zeros(n)
    pad_table = wavetable({k: 1.0 / k ** 1.4 for k in range(1, 13)})
    kick_s, snare_s, closed, open_ = kick(), snare(), hat(False), hat(True)
    rng = np.random.default_rng(1100)
    bar = 0
    for n_bars, root, chord in PROGRESSION:
        start = bar * BAR
        length = n_bars * BAR
        for step in range(n_bars * 8):  # bass: eighth notes
            accent = 1.0 if step % 2 == 0 else 0.6
            note = bass_note(midi_hz(root + BASS_STEPS[step % 8]), int(EIGHTH * 0.85), accent)
            mix_in(bass, start + step * EIGHTH, note * (0.8 + 0.2 * accent), wrap=True)
        m = length + samples(0.9)  # pad: swell in, overlap the next chord while fading out
        tt = clock(m)
        env = ramp(m, 0.5, 0.9) * (0.85 + 0.15 * np.sin(TAU * tt / (BAR / RATE)))
        voices = sum(play_table(pad_table, TAU * midi_hz(note) * detune * tt + TAU * rng.random())
                     for note in chord for detune in (0.996, 1.0, 1.0045))
        mix_in(pad, start, voices * env, wrap=True)
        bar += n_bars
    for b in range(bars):
        start = b * BAR
        for eighth in (0, 5):
            mix_in(drums, start + eighth * EIGHTH, kick_s, wrap=True)
        for beat in (1, 3):
            mix_in(drums, start + beat * BEAT, 0.55 * snare_s, wrap=True)
        for eighth in range(8):
            sample = open_ if (eighth == 7 and b % 2 == 1) else closed
            mix_in(drums, start + eighth * EIGHTH, (0.5 if eighth % 2 == 0 else 0.8) * 0.35 * sample, wrap=True)
        if b == bars - 1:  # turnaround fill: sixteenths on the last beat
            for s in range(4):
                mix_in(drums, start + 3 * BEAT + s * (EIGHTH // 2), (0.25 + 0.12 * s) * snare_s, wrap=True)
    pad = fft_filter(pad, lambda f: lowpass(f, 1100.0, 2), circular=True)
    bass = bass / np.max(np.abs(bass))
    pad = pad / np.max(np.abs(pad))
    drums = drums / np.max(np.abs(drums))
    mix = 0.55 * bass + 0.4 * pad + 0.6 * drums
    mix = fft_filter(mix, lambda f: lowpass(f, 6000.0, 1) * highpass(f, 30.0, 2), circular=True)
    return np.tanh(1.3 * mix / np.max(np.abs(mix)))


# --------------------------------------------------------------------------------------
# The catalogue, rendering, writing, checking
# --------------------------------------------------------------------------------------

@dataclass(frozen=True)
class Sound:
    """One asset: its file stem, how to make it, its peak level and whether it loops."""

    name: str
    make: Callable[[], np.ndarray]
    peak: float
    loop: bool
    about: str

    @property
    def filename(self) -> str:
        return f"{self.name}.wav"


SOUNDS: tuple[Sound, ...] = (
    Sound("launch", make_launch, 0.85, False, "energy ball thrown: rising whoosh + tone"),
    *(Sound(f"charge_{k}", lambda k=k: make_charge(k), 0.6, True,
            f"charging hum loop, {('low', 'mid', 'high')[k - 1]} charge (1 s, seamless)") for k in (1, 2, 3)),
    Sound("hit", make_hit, 0.95, False, "ball hits a zombie: boom + zap"),
    Sound("miss", make_miss, 0.5, False, "ball fizzles out"),
    Sound("wall", make_wall, 0.7, False, "ball bursts on a wall: thud + sparks"),
    *(Sound(f"groan_{k}", lambda k=k: make_groan(k), 0.7, False, f"zombie groan, variant {k}") for k in (1, 2, 3)),
    Sound("hurt", make_hurt, 0.9, False, "player is hurt: thud + crunch"),
    Sound("wave", make_wave, 0.8, False, "gong: a new wave begins"),
    Sound("game_over", make_game_over, 0.8, False, "descending tones: game over"),
    Sound("click", make_click, 0.5, False, "UI click"),
    Sound("music", make_music, 0.8, True, "background music loop, 100 bpm, 28.8 s, seamless"),
)
BY_NAME = {s.name: s for s in SOUNDS}


def render(sound: Sound) -> np.ndarray:
    """The sound's samples as int16: one-shots faded at both ends, normalised to its peak."""
    x = np.asarray(sound.make(), float)
    if not sound.loop:
        x = x * ramp(len(x), 0.0015, 0.01)
    x = x * (sound.peak / np.max(np.abs(x)))
    return np.clip(np.round(x * 32767.0), -32767, 32767).astype("<i2")


def wav_bytes(pcm: np.ndarray) -> bytes:
    """A complete 16-bit mono WAV file (header + data) for ``pcm``."""
    buffer = io.BytesIO()
    with wave.open(buffer, "wb") as w:
        w.setnchannels(1)
        w.setsampwidth(2)
        w.setframerate(RATE)
        w.writeframes(pcm.astype("<i2").tobytes())
    return buffer.getvalue()


def build(sound: Sound) -> bytes:
    """The exact bytes of the sound's WAV file."""
    return wav_bytes(render(sound))


def write_atomic(path: Path, data: bytes) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same folder and a rename."""
    path.parent.mkdir(parents=True, exist_ok=True)
    mode = path.stat().st_mode & 0o777 if path.exists() else 0o644  # mkstemp would leave 0600
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=f".{path.name}.", suffix=".tmp")
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(tmp, mode)
        os.replace(tmp, path)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise


def sha256(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def select(names: list[str] | None) -> list[Sound]:
    """The sounds named (all when ``names`` is empty); unknown names raise ValueError."""
    if not names:
        return list(SOUNDS)
    unknown = [n for n in names if n not in BY_NAME]
    if unknown:
        raise ValueError(f"unknown sound(s): {', '.join(unknown)}; known: {', '.join(BY_NAME)}")
    return [BY_NAME[n] for n in names]


def generate(out: Path, names: list[str] | None = None, report: Callable[[str], None] = print) -> list[dict]:
    """Write the WAVs into ``out`` (files already identical are left untouched)."""
    rows = []
    for sound in select(names):
        data = build(sound)
        path = out / sound.filename
        same = path.is_file() and path.read_bytes() == data
        if not same:
            write_atomic(path, data)
        row = {"file": sound.filename, "bytes": len(data), "seconds": round((len(data) - 44) / 2 / RATE, 3),
               "sha256": sha256(data), "status": "unchanged" if same else "wrote"}
        rows.append(row)
        report(f"{row['status']:9s} {path}  {row['seconds']:6.2f} s  {row['bytes'] / 1024:7.1f} KiB")
    return rows


def check(out: Path, names: list[str] | None = None, report: Callable[[str], None] = print) -> list[dict]:
    """Compare each file in ``out`` with a fresh render by sha256: status ok / differs / missing."""
    rows = []
    for sound in select(names):
        want = sha256(build(sound))
        path = out / sound.filename
        have = sha256(path.read_bytes()) if path.is_file() else None
        status = "missing" if have is None else ("ok" if have == want else "differs")
        rows.append({"file": sound.filename, "status": status, "expected_sha256": want, "actual_sha256": have})
        report(f"{status:8s} {path}")
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=HERE, help="folder for the WAV files (default: this script's folder)")
    parser.add_argument("--check", action="store_true", help="verify the files match a fresh render; exit 1 if not")
    parser.add_argument("--only", nargs="+", metavar="NAME", help=f"only these sounds ({', '.join(BY_NAME)})")
    parser.add_argument("--json", action="store_true", help="print the results as JSON")
    args = parser.parse_args(argv)
    quiet = (lambda line: None) if args.json else (lambda line: print(line, flush=True))
    try:
        rows = (check if args.check else generate)(args.out, args.only, quiet)
    except ValueError as exc:
        parser.error(str(exc))
    bad = [r for r in rows if r["status"] in ("differs", "missing")]
    if args.json:
        print(json.dumps({"out": str(args.out), "files": rows, "ok": not bad}, indent=2))
    elif args.check:
        print(f"{len(rows) - len(bad)}/{len(rows)} files match" + (
            "" if not bad else f"; run `python {Path(__file__).name} --out {args.out}` to regenerate"))
    else:
        print(f"{len(rows)} files, {sum(r['bytes'] for r in rows) / 1024 / 1024:.2f} MiB in {args.out}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
