"""Numerical safety of the waveguide: no growth once the forces stop, no NaN at the extremes.

Every junction is passive by construction (``engine.waveguide.pluck``: the bilinear image of a
positive-real point impedance; ``collision``: it only moves a point towards its rest line;
``string``: termination filters with |H| <= 1; ``fingering``).  The energy measured here is the
rails' (``WaveguideVoice.energy``: mu X (du/dt)^2 of both travelling waves over the sounding grid).
It leaves out what is in transit inside a termination's filters (a few samples of the loop), so it
is compared over windows, not sample by sample: once a string's last event has passed, the largest
energy in any later window may not exceed the largest in the first window after it.
"""

import numpy as np
import pytest
from pydantic import ValidationError

import engine
from benchmarks.stability import NumpyDraw, random_scene
from engine.waveguide import WaveguideOptions, prepare

BLOCK = 256
GROWTH = 1e-9  # relative: only rounding may add


def _soak(sc: dict, window_s: float = 0.05) -> tuple[bool, float]:
    """(finite, worst relative growth) of a scene on the waveguide."""
    scene = engine.parse_scene({**sc, "model": "waveguide"})
    inst = prepare(scene, WaveguideOptions(skip_decayed=False))
    rate = scene.sample_rate
    win = max(int(window_s * rate / BLOCK), 1)
    history = {v.index: [] for v in inst.voices}
    finite = True
    for block in inst.blocks(BLOCK):
        finite &= bool(np.isfinite(block).all())
        for v in inst.voices:
            if v.step > v.timeline.last_step + v.p0 + 8:
                history[v.index].append(v.energy())
    worst = 0.0
    for h in history.values():
        if len(h) > win:
            first = max(h[:win])
            if first > 0.0:
                worst = max(worst, max(h[win:]) / first - 1.0)
    return finite, worst


def _scenes(seed: int, count: int, **kw):
    d = NumpyDraw(np.random.default_rng(seed))
    out = []
    while len(out) < count:
        sc = random_scene(d, **kw)
        try:
            engine.parse_scene(sc)
        except ValidationError:
            continue
        out.append(sc)
    return out


def test_random_scenes_never_grow():
    """60 random valid scenes (every preset, overrides, rates 22.05-96 kHz, up to 12 events of
    every kind, forces up to the limits), 0.3-1.5 s."""
    worst = []
    for sc in _scenes(1, 60, max_duration=1.5, min_duration=0.3, max_events=12):
        finite, growth = _soak(sc)
        assert finite, sc
        worst.append(growth)
    assert max(worst) <= GROWTH, max(worst)


@pytest.mark.slow
def test_long_random_scenes_never_grow():
    """Four 20 s scenes: a long soak."""
    for sc in _scenes(2, 4, max_duration=20.0, min_duration=20.0, max_events=4):
        finite, growth = _soak(sc, window_s=0.2)
        assert finite and growth <= GROWTH, (sc, growth)


EXTREMES = [
    # the hardest plucks of every style on every preset, at the lowest and highest rates
    *({"duration": 0.5, "sample_rate": rate, "guitar": {"preset": p},
       "events": [{"type": "pluck", "time": 0.0, "string": s, "force": 20.0, "style": st,
                   "position": pos}
                  for s in (1, engine.get_preset(p).n_strings)
                  for st, pos in (("slap", 0.02), ("pop", 0.98), ("pick", 0.5),
                                  ("finger", 0.8))]}
      for p in engine.PRESETS for rate in (22050, 96000)),
    # bends and vibrato at their limits, slides over the whole neck in a millisecond
    {"duration": 0.6, "sample_rate": 22050, "guitar": {"preset": "electric", "frets": 24},
     "events": [{"type": "fret", "time": 0.0, "string": 1, "fret": 24, "force": 10.0},
                {"type": "pluck", "time": 0.01, "string": 1, "force": 20.0},
                {"type": "bend", "time": 0.02, "string": 1, "semitones": 3.0,
                 "duration": 0.001, "release": 0.1},
                {"type": "vibrato", "time": 0.0, "string": 2, "depth_cents": 100.0,
                 "rate_hz": 15.0, "duration": 0.5},
                {"type": "pluck", "time": 0.0, "string": 2, "force": 20.0},
                {"type": "slide", "time": 0.0, "string": 3, "from_fret": 1, "to_fret": 24,
                 "duration": 0.001, "force": 10.0},
                {"type": "pluck", "time": 0.0, "string": 3, "force": 20.0, "style": "pop"},
                {"type": "tap", "time": 0.0, "string": 4, "fret": 24, "velocity": 5.0},
                {"type": "hammer_on", "time": 0.01, "string": 4, "fret": 1, "velocity": 5.0},
                {"type": "pull_off", "time": 0.02, "string": 4, "fret": 24, "force": 20.0},
                {"type": "mute", "time": 0.0, "string": 5, "amount": 1.0, "position": 0.7},
                {"type": "harmonic", "time": 0.0, "string": 5, "position": 0.021},
                {"type": "pluck", "time": 0.0, "string": 5, "force": 20.0},
                {"type": "strum", "time": 0.3, "spread": 0.0, "force": 20.0,
                 "style": "slap"}]},
    # a string at the edges of the overrides: light and slack, heavy and stiff
    {"duration": 0.5, "sample_rate": 96000,
     "guitar": {"preset": "steel-acoustic", "action_nut_m": 1e-4, "action_12th_m": 8e-3,
                "strings": [{"string": 1, "radius_m": 5e-5, "density_kg_m3": 500.0,
                             "note": "C1", "t60_fundamental_s": 60.0, "t60_2khz_s": 60.0},
                            {"string": 6, "radius_m": 2e-3, "density_kg_m3": 25000.0,
                             "youngs_modulus_pa": 1e8, "note": "F6",
                             "t60_fundamental_s": 0.05, "t60_2khz_s": 0.02}]},
     "events": [{"type": "pluck", "time": 0.0, "string": 1, "force": 20.0, "style": "slap"},
                {"type": "pluck", "time": 0.0, "string": 6, "force": 20.0, "style": "pop"},
                {"type": "fret", "time": 0.1, "string": 6, "fret": 20, "force": 0.01}]},
]


@pytest.mark.parametrize("sc", EXTREMES)
def test_no_nan_at_the_extremes(sc):
    sc = {**sc, "output": {"body": "none", "normalize": False}}
    finite, growth = _soak(sc)
    assert finite and growth <= GROWTH, growth
