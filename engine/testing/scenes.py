"""Scene builders: the one set the tests and the benchmarks use.

Scenes are plain dicts in the format of ``../shared/API.md``; these helpers only fill in the
fields a measurement cares about, with the defaults the physics checks use.  A benchmark that
needs other values (the Pareto study's 2 N plucks and preset finger forces, say) passes them.
"""

from __future__ import annotations

SR = 44100


def scene(events: list, duration: float = 1.0, **extra) -> dict:
    """A scene dict; the string's own sound (no body response) unless ``output`` says otherwise:
    the physics checks measure the strings, and a body resonance near a partial moves a spectral
    peak."""
    return {"duration": duration, "sample_rate": SR, "events": events,
            "output": {"body": "none"}, **extra}


def pluck(string: int, time: float = 0.0, force: float = 1.0, position: float = 0.8,
          **kw) -> dict:
    return {"type": "pluck", "time": time, "string": string, "force": force,
            "position": position, **kw}


def fret(string: int, fret: int, time: float = 0.0, force: float | None = 3.0, **kw) -> dict:
    """A finger behind ``fret``; ``force=None`` leaves the force out, so the finger presses with
    the engine's default (the preset's force, or more where the string needs it to seat)."""
    ev = {"type": "fret", "time": time, "string": string, "fret": fret, "force": force, **kw}
    if force is None:
        del ev["force"]
    return ev


def tap(string: int, fret: int, time: float = 0.0, force: float = 1.0, velocity: float = 1.0,
        **kw) -> dict:
    return {"type": "tap", "time": time, "string": string, "fret": fret, "force": force,
            "velocity": velocity, **kw}


def song(seconds: float, quality: str = "draft", note_every_s: float = 4.0) -> dict:
    """Two tracks (an electric lead through drive, delay and reverb, and a bass), one plucked and
    damped note per track every ``note_every_s`` seconds, on strings that change from note to note."""
    lead, bass = [], []
    t = 0.0
    i = 0
    while t + note_every_s <= seconds:
        s = 1 + i % 3
        lead += [{"type": "fret", "time": t, "string": s, "fret": 2 + i % 5},
                 {"type": "pluck", "time": t + 0.01, "string": s},
                 {"type": "damp", "time": t + 0.8, "string": s}]
        bass += [{"type": "pluck", "time": t + 0.5 * note_every_s, "string": 1 + i % 2},
                 {"type": "damp", "time": t + 0.5 * note_every_s + 0.8, "string": 1 + i % 2}]
        t += note_every_s
        i += 1
    return {"duration": seconds, "quality": quality, "output": {"channels": 2},
            "tracks": [
                {"name": "Lead", "guitar": {"preset": "electric"}, "events": lead, "pan": -0.3,
                 "effects": [{"type": "drive", "gain_db": 12}, {"type": "delay", "delay_s": 0.3},
                             {"type": "reverb", "room_size": 0.6}]},
                {"name": "Bass", "guitar": {"preset": "bass"}, "events": bass, "pan": 0.2,
                 "gain_db": -3.0}]}


# ---- the speed tables' scenes (``benchmarks.speed``, ``tools.compare``, ``tools.instructions``) --

# the per-string table's linear string: no Kirchhoff-Carrier, fretboard or frets
LINEAR = {"kirchhoff_carrier": False, "fretboard": False, "frets": False, "skip_decayed": False}


def pluck_events(string: int, force: float) -> list[dict]:
    """The per-string table's open-string pluck at time 0 (8 N against the fretted note, 2 N for
    the open string's full model)."""
    return [{"type": "pluck", "time": 0.0, "string": string, "force": force}]


def strum_events(force: float = 2.0) -> list[dict]:
    """The open six-string strum: plucks 20 ms apart, low string first."""
    return [{"type": "pluck", "time": 0.02 * i, "string": 6 - i, "force": force} for i in range(6)]


CHORD_FRETS = {6: 3, 5: 2, 4: 0, 3: 0, 2: 1, 1: 0}  # C major


def chord_events() -> list[dict]:
    """A fretted C major chord (strings 4, 3 and 1 open), strummed like ``strum_events``."""
    chord = [{"type": "fret", "time": 0.0, "string": s, "fret": q}
             for s, q in CHORD_FRETS.items() if q > 0]
    return chord + [{"type": "pluck", "time": 0.05 + 0.02 * i, "string": 6 - i, "force": 2.0}
                    for i in range(6)]


def fretted_events(string: int) -> list[dict]:
    """The fretted full model of the per-string table: a finger at fret 5, an 8 N pluck."""
    return [{"type": "fret", "time": 0.0, "string": string, "fret": 5},
            {"type": "pluck", "time": 0.05, "string": string, "force": 8.0}]


CG_CHORD = {6: 3, 5: 3, 4: 2, 3: 0, 2: 1, 1: 0}  # C/G: the waveguide benchmark's chord


def strum_scene() -> dict:
    """The fretted C/G strum of ``benchmarks.waveguide`` and ``tools.instructions``: the fingers
    down at 0, a 2 N strum at 50 ms, 4 s."""
    evs = [fret(s, q) for s, q in CG_CHORD.items() if q > 0]
    evs.append({"type": "strum", "time": 0.05, "force": 2.0, "spread": 0.03})
    return scene(evs, 4.0)
