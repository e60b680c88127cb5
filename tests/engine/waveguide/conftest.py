"""Helpers of the waveguide tests: render a scene dict with the waveguide model (pickup velocity,
m/s, no body), and measure pitch the way the finite-difference tests do."""

import numpy as np
import pytest

import engine
from engine import waveguide
from engine.analysis import cents, spectrum_peak
from engine.models import PRESSED_STRING
from engine.testing.scenes import SR, fret, pluck, scene  # noqa: F401  (the tests' builders)


def render(events: list, duration: float, options=None, **extra) -> np.ndarray:
    sc = engine.parse_scene({**scene(events, duration, **extra), "model": "waveguide"})
    audio = waveguide.render(sc, options, statics=PRESSED_STRING)
    assert np.isfinite(audio).all()
    return audio


def pitch_cents(audio: np.ndarray, target: float, start: float = 0.2, stop: float | None = None,
                sr: int = SR, rel_width: float = 0.08) -> float:
    """The strongest peak within ``rel_width`` of ``target`` between start and stop (s), in cents
    from ``target``."""
    seg = audio[int(start * sr):None if stop is None else int(stop * sr)]
    return float(cents(spectrum_peak(seg, sr, target, rel_width), target))


@pytest.fixture(scope="session")
def presets():
    return {name: engine.get_preset(name) for name in engine.PRESETS}
