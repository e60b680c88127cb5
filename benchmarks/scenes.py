"""Scene builders shared by the benchmarks and the engine tests (``tests/engine/conftest.py``).

Scenes are plain dicts in the format of ``../shared/API.md``; these helpers only fill in the
fields a measurement cares about, with the defaults the physics checks use.
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


def fret(string: int, fret: int, time: float = 0.0, force: float = 3.0, **kw) -> dict:
    return {"type": "fret", "time": time, "string": string, "fret": fret, "force": force, **kw}


def tap(string: int, fret: int, time: float = 0.0, force: float = 1.0, velocity: float = 1.0,
        **kw) -> dict:
    return {"type": "tap", "time": time, "string": string, "fret": fret, "force": force,
            "velocity": velocity, **kw}
