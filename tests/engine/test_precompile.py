"""Kernels compiled once, in one place (``engine.precompile``): after ``prepare_kernels`` numba's
cache holds what a render of that model calls, and ``kernels_cached`` says so; a render then
compiles nothing; and the process that had them compiled renders what later processes render."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

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


def test_a_cache_compiled_from_other_sources_is_flushed(monkeypatch):
    """numba keys a kernel's cache by its own file; the stamp of the kernels' sources says when
    a helper in another file changed: the kernels are then not cached, and the caches of every
    compiled function of those sources are flushed before they are compiled again (the held run,
    cached under runs.py, inlines the frets' check of collisions.py)."""
    if not config.JIT["cache"]:
        pytest.skip("numba's cache is off (GUITAR_NUMBA_CACHE=0)")
    precompile.prepare_kernels(["waveguide"])  # loads (or compiles) and stamps
    assert precompile.kernels_cached(["waveguide"])
    monkeypatch.setattr(precompile, "sources_digest", lambda: "0" * 64)  # a pull changed a helper
    assert not precompile.kernels_cached(["waveguide"])
    flushed = []
    every = precompile._kernel_dispatchers()
    for d in every:
        monkeypatch.setattr(d._cache, "flush", lambda d=d: flushed.append(d))
    monkeypatch.setattr(precompile, "_compile_in_children", lambda argvs: None)
    precompile._compile(["waveguide"], [])
    names = {f"{d.py_func.__module__}.{d.py_func.__name__}" for d in flushed}
    assert len(flushed) == len(every)
    assert {"engine.waveguide.kernel.run_block", "engine.fd.kernels.runs._held_run",
            "engine.fd.kernels.collisions._fret_hit", "engine.output._modal"} <= names


def test_kernels_cached_is_false_for_an_empty_cache(monkeypatch):
    class Empty:
        def _load_index(self):
            return {}

    d = precompile._dispatchers("fdtd")[0]
    monkeypatch.setattr(d._cache, "_cache_file", Empty(), raising=False)
    assert not precompile.kernels_cached(["fdtd"])


def test_warm_calibrations_leave_a_waveguide_song_nothing_to_compute(tmp_path, monkeypatch):
    """After ``warm_calibrations`` (``make install``), a waveguide render of held notes anywhere on
    the neck computes no calibration: the loops' dispersion filters and the finger's damping of
    every fret are in the store."""
    from engine import calibration_store
    from engine.waveguide import fingering
    from engine.waveguide import string as wg_string

    def forget():
        calibration_store.reset()
        fingering.finger_decay_db_s.cache_clear()
        wg_string.dispersion_filter.cache_clear()

    monkeypatch.setattr(config, "CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(config, "CALIBRATION_CACHE", True)
    forget()
    try:
        precompile.warm_calibrations(["bass"], models=("waveguide",))
        forget()  # a new process: only the store
        computed = []
        calibration_store.on_compute(computed.append)
        events = [e for s, q in ((1, 17), (2, 5), (3, 11), (4, 2))
                  for e in ({"type": "fret", "time": 0.0, "string": s, "fret": q},
                            {"type": "pluck", "time": 0.01, "string": s})]
        engine.render({"duration": 0.1, "model": "waveguide", "guitar": {"preset": "bass"},
                       "events": events})
        assert computed == []
    finally:
        calibration_store.on_compute(None)
        forget()


# a fretted note, a pluck and a tap through the body: with fastmath, the process that compiled the
# finite-difference kernels rendered it up to 7e-11 of its peak away from every later process
# (``tools.render_digest --first-process``, its scene ``api-example``)
_FIRST = r"""
import hashlib, json, sys
import numpy as np
import engine
engine.prepare_kernels({"fdtd"})
y = np.asarray(engine.render(json.loads(sys.argv[1])))
print(hashlib.sha256(y.tobytes()).hexdigest())
"""


def test_the_process_that_compiles_renders_what_later_processes_render(tmp_path):
    """``prepare_kernels`` compiles in a child process and loads what it cached, so the first
    render on a machine has the samples of every later one."""
    if not config.JIT["cache"]:
        pytest.skip("numba's cache is off (GUITAR_NUMBA_CACHE=0)")
    import json

    from tools.render_digest import SCENES

    root = Path(__file__).resolve().parents[2]
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path), "PYTHONPATH": str(root)}
    digests = [subprocess.run([sys.executable, "-c", _FIRST, json.dumps(SCENES["api-example"])],
                              env=env, cwd=root, capture_output=True, text=True, timeout=900,
                              check=True).stdout.strip()
               for _ in range(2)]  # the first compiles (into the empty cache), the second loads
    assert digests[0] and digests[0] == digests[1]


def test_each_model_is_compiled_by_a_child_of_its_own_at_once(monkeypatch):
    """Kernels that must be compiled are compiled in children, one per string model, started
    together (``compile_jobs`` at a time); a child compiles its own model's and flushes nothing."""
    if not config.JIT["cache"]:
        pytest.skip("numba's cache is off (GUITAR_NUMBA_CACHE=0)")
    started, waited = [], []

    class Child:
        def __init__(self, argv, **kw):
            assert kw["env"][precompile.CHILD_ENV] == "1"
            started.append((argv[3:], len(waited)))

        def wait(self):
            waited.append(1)

    monkeypatch.setattr(precompile.subprocess, "Popen", Child)
    monkeypatch.setattr(precompile, "kernels_cached", lambda models: False)
    monkeypatch.delenv(precompile.CHILD_ENV, raising=False)
    monkeypatch.setenv("GUITAR_COMPILE_JOBS", "2")
    precompile._compile(["fdtd", "waveguide"], [["--kernels-only", "--models", m]
                                                for m in ("fdtd", "waveguide")])
    # both started before either was waited for
    assert started == [(["--kernels-only", "--models", "fdtd"], 0),
                       (["--kernels-only", "--models", "waveguide"], 0)]
    started.clear()
    waited.clear()
    monkeypatch.setenv("GUITAR_COMPILE_JOBS", "1")  # one after the other
    precompile._compile(["fdtd", "waveguide"], [["--models", "fdtd"], ["--models", "waveguide"]])
    assert started == [(["--models", "fdtd"], 0), (["--models", "waveguide"], 1)]
    # in a child: neither a flush nor a grandchild
    started.clear()
    monkeypatch.setenv(precompile.CHILD_ENV, "1")
    monkeypatch.setattr(precompile, "_kernel_dispatchers", lambda: pytest.fail("flushed"))
    precompile._compile(["fdtd"], [["--models", "fdtd"]])
    assert started == []


@pytest.mark.parametrize("value", ["0", "-1", "two", "1.5"])
def test_a_bad_compile_jobs_names_the_variable(monkeypatch, value):
    monkeypatch.setenv("GUITAR_COMPILE_JOBS", value)
    with pytest.raises(ValueError, match="GUITAR_COMPILE_JOBS: a positive integer"):
        precompile.compile_jobs()


def test_warmup_of_one_model_renders_only_its_scenes(monkeypatch):
    rendered = []
    monkeypatch.setattr(precompile, "kernels_cached", lambda models: True)
    monkeypatch.setattr(precompile, "render", lambda scene: rendered.append(scene))
    precompile.warmup(["waveguide"])
    assert rendered == [s for s in precompile.WARMUP_SCENES if s.get("model") == "waveguide"]
    rendered.clear()
    precompile.warmup()
    assert rendered == list(precompile.WARMUP_SCENES)
