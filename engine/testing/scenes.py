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
