"""Measurements on rendered audio: partial frequencies, pitch in cents, levels.

Shared by the tests and the benchmarks so that both judge the engine with the same ruler.
"""

from __future__ import annotations

import numpy as np


def cents(f: float | np.ndarray, ref: float | np.ndarray) -> float | np.ndarray:
    return 1200.0 * np.log2(np.asarray(f) / np.asarray(ref))


def spectrum_peak(x: np.ndarray, sr: float, f_guess: float, rel_width: float = 0.03,
                  pad: int = 8) -> float:
    """Frequency of the strongest spectral peak within f_guess * (1 +- rel_width).

    Hann window, zero-padding by ``pad`` and parabolic interpolation on the log magnitude: for a
    decaying partial in a 1 s window this resolves a few hundredths of a hertz.
    """
    n = len(x)
    nfft = 1 << int(np.ceil(np.log2(n * pad)))
    spec = np.abs(np.fft.rfft(x * np.hanning(n), nfft))
    freqs = np.fft.rfftfreq(nfft, 1.0 / sr)
    lo = np.searchsorted(freqs, f_guess * (1.0 - rel_width))
    hi = np.searchsorted(freqs, f_guess * (1.0 + rel_width))
    i = lo + int(np.argmax(spec[lo:hi]))
    if 0 < i < len(spec) - 1:
        a, b, c = np.log(spec[i - 1 : i + 2] + 1e-300)
        den = a - 2 * b + c
        delta = 0.5 * (a - c) / den if den != 0 else 0.0
    else:
        delta = 0.0
    return float((i + delta) * sr / nfft)


def partials(x: np.ndarray, sr: float, f1_guess: float, count: int, inharmonicity: float = 0.0,
             rel_width: float = 0.02) -> np.ndarray:
    """Frequencies of partials 1..count, each searched near n f1 sqrt(1 + B n^2)."""
    n = np.arange(1, count + 1)
    guesses = n * f1_guess * np.sqrt(1.0 + inharmonicity * n**2) / np.sqrt(1.0 + inharmonicity)
    return np.array([spectrum_peak(x, sr, g, rel_width) for g in guesses])


def level_db(x: np.ndarray) -> float:
    rms = float(np.sqrt(np.mean(np.square(x)))) if len(x) else 0.0
    return 20.0 * np.log10(rms + 1e-300)


def band_level_db(x: np.ndarray, sr: float, f: float, rel_width: float = 0.03) -> float:
    """Peak spectral magnitude (dB) within f (1 +- rel_width)."""
    n = len(x)
    spec = np.abs(np.fft.rfft(x * np.hanning(n), 4 * n))
    freqs = np.fft.rfftfreq(4 * n, 1.0 / sr)
    sel = (freqs > f * (1 - rel_width)) & (freqs < f * (1 + rel_width))
    return float(20.0 * np.log10(spec[sel].max() + 1e-300))


def pitch_track(x: np.ndarray, sr: float, f_guess: float, window_s: float = 0.06,
                hop_s: float = 0.005, rel_width: float = 0.1) -> tuple[np.ndarray, np.ndarray]:
    """Times (window centres, s) and frequencies of the peak near f_guess in short windows."""
    w = int(window_s * sr)
    hop = int(hop_s * sr)
    starts = np.arange(0, len(x) - w, hop)
    f = np.array([spectrum_peak(x[s : s + w], sr, f_guess, rel_width) for s in starts])
    return (starts + w / 2) / sr, f


def decay_db_per_s(x: np.ndarray, sr: float, f: float, start: float = 0.2,
                   stop: float = 1.15) -> float:
    """Slope (dB/s) of a line fitted to the level of the component at f Hz in 0.1 s Hann windows
    every 0.05 s from ``start`` to ``stop`` seconds (negative: it decays)."""
    n = int(0.1 * sr)
    window = np.hanning(n)
    tone = np.exp(-2j * np.pi * f * np.arange(n) / sr)
    times = np.arange(start, stop - 0.1 + 1e-9, 0.05)
    level = [20.0 * np.log10(abs(np.sum(x[int(t * sr):int(t * sr) + n] * window * tone)))
             for t in times]
    return float(np.polyfit(times, level, 1)[0])
