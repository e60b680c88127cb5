"""Each skip is bounded: the output with the skip against the output without it."""

import time

import numpy as np

from engine.guitar import RenderOptions, prepare
from engine.scene import Scene

from .conftest import fret, pluck, scene


def _render(sc, **opts):
    eng = prepare(Scene.model_validate(sc), RenderOptions(**opts))
    t = time.perf_counter()
    out = np.concatenate(list(eng.blocks()))
    return out, eng, time.perf_counter() - t


def test_silent_strings_are_not_simulated_and_contribute_exactly_zero():
    sc = scene([pluck(1, force=2.0)], duration=0.2)
    with_skip, eng, _ = _render(sc)
    without, eng_all, _ = _render(sc, skip_silent=False)
    assert len(eng.voices) == 1 and len(eng_all.voices) == 6
    assert np.array_equal(with_skip, without)


def test_unreachable_frets_are_skipped_exactly():
    """The rigid frets are looked at only when one is within reach: bit-identical output."""
    sc = scene([pluck(6, force=20.0, duration=1e-4), pluck(1, force=20.0, duration=1e-4),
                fret(3, 2), pluck(3, time=0.02, force=10.0)], duration=0.3)
    a, _, _ = _render(sc)
    b, _, _ = _render(sc, skip_contacts=False)
    assert np.array_equal(a, b)


def test_decayed_strings_stop_with_a_bounded_difference():
    """A short note in a long scene: the string stops once every node moves slower than
    1e-7 m/s; the output differs by less than 1e-6 m/s (-128 dB of the fixed gain's full scale)."""
    sc = scene([fret(1, 5, force=3.0), pluck(1, time=0.0, force=2.0),
                {"type": "fret", "time": 0.5, "string": 1, "fret": 0}], duration=12.0)
    sc["guitar"] = {"strings": [{"string": 1, "t60_fundamental_s": 0.5, "t60_2khz_s": 0.2}]}
    a, eng, t_skip = _render(sc)
    b, _, t_full = _render(sc, skip_decayed=False)
    assert eng.voices[0].stopped
    peak = np.abs(b).max()
    assert peak > 1e-2
    assert np.abs(a - b).max() < 1e-6
    assert t_skip < t_full
