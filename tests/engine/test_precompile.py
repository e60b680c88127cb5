"""Kernels compiled once, in one place (``engine.precompile``): after ``prepare_kernels`` numba's
cache holds what a render of that model calls, and ``kernels_cached`` says so; a render then
compiles nothing."""

from __future__ import annotations

import pytest

import engine
from engine import config, precompile


@pytest.mark.parametrize("model", ["fdtd", "waveguide"])
def test_prepare_kernels_leaves_them_cached(model):
    if not config.JIT["cache"]:
        pytest.skip("numba's cache is off (GUITAR_NUMBA_CACHE=0)")
    precompile.prepare_kernels([model])
    assert precompile.kernels_cached([model])
    # a render of that model now loads nothing more and compiles nothing
    before = {id(d): len(d.signatures) for d in precompile._dispatchers(model)}
    engine.render({"duration": 0.05, "model": model, "quality": "standard",
                   "events": [{"type": "fret", "time": 0.0, "string": 1, "fret": 9},
                              {"type": "pluck", "time": 0.0, "string": 1},
                              {"type": "pluck", "time": 0.01, "string": 4}]})
    assert {id(d): len(d.signatures) for d in precompile._dispatchers(model)} == before


def test_kernels_cached_is_false_for_an_empty_cache(monkeypatch):
    class Empty:
        def _load_index(self):
            return {}

    d = precompile._dispatchers("fdtd")[0]
    monkeypatch.setattr(d._cache, "_cache_file", Empty(), raising=False)
    assert not precompile.kernels_cached(["fdtd"])
