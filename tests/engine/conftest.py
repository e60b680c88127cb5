import pytest

from engine.presets import get_preset

SR = 44100


@pytest.fixture(scope="session")
def steel():
    return get_preset("steel-acoustic")


def scene(events, duration=1.0, **extra):
    """A scene dict; the string's own sound (no body response) unless ``output`` says otherwise:
    the physics tests measure the strings, and a body resonance near a partial moves a spectral
    peak."""
    return {"duration": duration, "sample_rate": SR, "events": events,
            "output": {"body": "none"}, **extra}


def pluck(string, time=0.0, force=1.0, position=0.8, **kw):
    return {"type": "pluck", "time": time, "string": string, "force": force,
            "position": position, **kw}


def fret(string, fret, time=0.0, force=3.0, **kw):
    return {"type": "fret", "time": time, "string": string, "fret": fret, "force": force, **kw}


def tap(string, fret, time=0.0, force=1.0, velocity=1.0, **kw):
    return {"type": "tap", "time": time, "string": string, "fret": fret, "force": force,
            "velocity": velocity, **kw}
