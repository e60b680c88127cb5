"""The playable guitar's targets, measured on rendered audio (steel-acoustic, 44.1 kHz, no body).

``tests/engine/test_articulations.py`` asserts on these measurements and
``benchmarks/articulations.py`` prints them as a table, so the table and the tests cannot
disagree.
"""

from __future__ import annotations

import numpy as np

import engine
from engine.analysis import band_level_db, cents, level_db, pitch_track, spectrum_peak
from engine.testing.scenes import SR, fret, pluck, scene

STEEL = engine.get_preset("steel-acoustic")


def render(events: list, duration: float) -> tuple[np.ndarray, float]:
    """Audio and the largest relative energy-balance deviation over the strings."""
    r = engine.render(scene(events, duration), diagnostics=True)
    if not np.isfinite(r.audio).all():
        raise FloatingPointError("non-finite audio")
    return r.audio, r.energy_error


def note(string: int, q: float) -> float:
    """12-TET pitch of ``string`` stopped at fret q (Hz)."""
    return STEEL.strings[string - 1].frequency_hz * 2 ** (q / 12)


def pitch(audio: np.ndarray, t0: float, t1: float, f: float) -> float:
    """Cents of the spectral peak near f in [t0, t1) from f."""
    return float(cents(spectrum_peak(audio[int(t0 * SR):int(t1 * SR)], SR, f, 0.08), f))


def bend() -> dict:
    """A 2-semitone bend on string 2, held: cents from the target pitch."""
    a, e = render([pluck(2, force=2.0), {"type": "bend", "time": 0.2, "string": 2,
                                          "semitones": 2.0, "duration": 0.15}], 1.2)
    return {"held": pitch(a, 0.5, 1.1, note(2, 2)), "energy": e}


def bend_release() -> dict:
    a, e = render([pluck(2, force=2.0), {"type": "bend", "time": 0.1, "string": 2,
                                          "semitones": 1.0, "duration": 0.1, "release": 0.4}], 1.4)
    return {"held": pitch(a, 0.2, 0.4, note(2, 1)), "released": pitch(a, 0.7, 1.4, note(2, 0)),
            "energy": e}


def vibrato(depth: float = 30.0, rate: float = 5.0) -> dict:
    """Vibrato on string 1: the rate and half the peak-to-peak depth of the pitch track."""
    a, e = render([pluck(1, force=1.0), {"type": "vibrato", "time": 0.3, "string": 1,
                                          "depth_cents": depth, "rate_hz": rate,
                                          "duration": 1.5}], 2.0)
    t, f = pitch_track(a, SR, note(1, 0))
    c = cents(f[(t > 0.5) & (t < 1.7)], note(1, 0))
    spec = np.abs(np.fft.rfft((c - c.mean()) * np.hanning(len(c)), 8 * len(c)))
    measured_rate = float(np.fft.rfftfreq(8 * len(c), t[1] - t[0])[np.argmax(spec)])
    measured_depth = float((np.percentile(c, 98) - np.percentile(c, 2)) / 2)
    return {"rate_hz": measured_rate, "depth_cents": measured_depth, "asked_rate_hz": rate,
            "asked_depth_cents": depth, "energy": e}


def slide() -> dict:
    """Fret 5 to 7 on string 3: cents from each fret's pitch, before and after."""
    a, e = render([fret(3, 5), pluck(3, time=0.05), {"type": "slide", "time": 0.4, "string": 3,
                                                       "from_fret": 5, "to_fret": 7,
                                                       "duration": 0.15}], 1.5)
    return {"before": pitch(a, 0.2, 0.4, note(3, 5)), "after": pitch(a, 0.7, 1.5, note(3, 7)),
            "energy": e}


def hammer_on() -> dict:
    a, e = render([fret(3, 5), pluck(3, time=0.05),
                   {"type": "hammer_on", "time": 0.4, "string": 3, "fret": 7}], 1.5)
    return {"after": pitch(a, 0.6, 1.5, note(3, 7)), "energy": e}


def pull_off() -> dict:
    a, e = render([fret(3, 5), {"type": "hammer_on", "time": 0.0, "string": 3, "fret": 7},
                   pluck(3, time=0.05), {"type": "pull_off", "time": 0.4, "string": 3,
                                          "fret": 7}], 1.5)
    return {"before": pitch(a, 0.15, 0.4, note(3, 7)), "after": pitch(a, 0.6, 1.5, note(3, 5)),
            "energy": e}


def harmonic(q: int) -> dict:
    """A light touch over fret q of string 1, plucked near the bridge: the levels (dB) of
    partials 1-5 after the touch is released."""
    a, e = render([{"type": "harmonic", "time": 0.0, "string": 1, "fret": q, "release": 0.3},
                   pluck(1, time=0.02, force=2.0, position=0.85)], 1.2)
    a = a[int(0.4 * SR):]
    levels = {n: band_level_db(a, SR, n * note(1, 0)) for n in range(1, 6)}
    return {"levels": levels, "loudest": max(levels, key=levels.get), "energy": e}


def palm_mute() -> dict:
    """Level 0.5-0.6 s after a pluck, muted against open (dB)."""
    open_, e1 = render([pluck(1, force=2.0)], 1.0)
    muted, e2 = render([{"type": "mute", "time": 0.0, "string": 1}, pluck(1, force=2.0)], 1.0)
    late = slice(int(0.5 * SR), int(0.6 * SR))
    return {"drop_db": level_db(open_[late]) - level_db(muted[late]), "energy": max(e1, e2)}


def dead_note() -> dict:
    """A finger resting without pressing, against a pressed one: level 0.5-0.6 s (dB)."""
    fretted, e1 = render([fret(3, 5), pluck(3, time=0.05)], 0.8)
    dead, e2 = render([fret(3, 5, force=0.05), pluck(3, time=0.05)], 0.8)
    late = slice(int(0.5 * SR), int(0.6 * SR))
    return {"drop_db": level_db(fretted[late]) - level_db(dead[late]), "energy": max(e1, e2)}
