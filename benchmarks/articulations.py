"""The playable guitar's targets, measured on rendered audio (steel-acoustic, 44.1 kHz, no body).

    python -m benchmarks.articulations

Prints one row per target of the articulation issue: what is measured, the value, the limit.
``tests/engine/test_articulations.py`` asserts on the same measurements (the functions below), so
the table and the tests cannot disagree.
"""

from __future__ import annotations

import numpy as np

import engine
from benchmarks.scenes import SR, fret, pluck, scene
from engine.analysis import band_level_db, cents, level_db, pitch_track, spectrum_peak

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


def main() -> None:
    rows = []
    b = bend()
    rows.append(("bend 2 semitones, held (cents from target)", f"{b['held']:+.2f}", "±10"))
    r = bend_release()
    rows.append(("bend 1 semitone held / released (cents)",
                 f"{r['held']:+.2f} / {r['released']:+.2f}", "±10"))
    v = vibrato()
    rows.append(("vibrato 5 Hz, 30 cents: rate (Hz) / depth (cents)",
                 f"{v['rate_hz']:.2f} / {v['depth_cents']:.1f}", "±20 %"))
    s = slide()
    rows.append(("slide 5 -> 7, string 3: before / after (cents)",
                 f"{s['before']:+.2f} / {s['after']:+.2f}", "±10"))
    h = hammer_on()
    rows.append(("hammer-on 5 -> 7 (cents from fret 7)", f"{h['after']:+.2f}", "±10"))
    p = pull_off()
    rows.append(("pull-off 7 -> 5: before / after (cents)",
                 f"{p['before']:+.2f} / {p['after']:+.2f}", "±10"))
    h12, h7 = harmonic(12), harmonic(7)
    lv = h12["levels"]
    rows.append(("harmonic at fret 12: partial 1 below partial 2 (dB)",
                 f"{lv[2] - lv[1]:.1f}", ">= 20"))
    rows.append(("harmonic at fret 7: loudest partial", str(h7["loudest"]), "3"))
    rows.append(("palm mute: level 0.5 s after the pluck, below open (dB)",
                 f"{palm_mute()['drop_db']:.1f}", ">= 20"))
    rows.append(("dead note: level 0.5 s after the pluck, below fretted (dB)",
                 f"{dead_note()['drop_db']:.1f}", ">= 20"))
    worst = max(x["energy"] for x in (b, r, v, s, h, p, h12, h7))
    rows.append(("energy balance, worst of the scenes above", f"{worst:.1e}", "<= 1e-11"))
    w = max(len(r[0]) for r in rows)
    print(f"{'target':{w}s} | {'measured':>13s} | limit")
    for name, val, lim in rows:
        print(f"{name:{w}s} | {val:>13s} | {lim}")


if __name__ == "__main__":
    main()
