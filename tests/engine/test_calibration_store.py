"""Fret calibrations on disk (``engine.calibration_store``): a calibration read back is the one
computed, to the last bit; a render is the same with the store cold, warm or off, on both models
(the waveguide keeps the finger's damping of its held notes there); a process that finds its
strings there solves nothing; a store that cannot be written changes nothing."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

import engine
from engine import calibration_store, config
from engine.fd import intonation, statics
from engine.fd import string as fd_string
from engine.fd.instrument import prepare
from engine.models import PRESSED_STRING
from engine.scene import Scene
from engine.testing.scenes import fret, pluck, scene
from engine.waveguide import fingering
from engine.waveguide import string as wg_string

SCENE = scene([fret(2, 7), pluck(2, time=0.01, force=2.0)], 0.1)
WAVEGUIDE = {**scene([fret(2, 7), fret(5, 3), pluck(2, time=0.01, force=2.0),
                      pluck(5, time=0.02)], 0.3), "model": "waveguide"}


def _forget() -> None:
    """The process's own caches of what the store keeps."""
    calibration_store.reset()
    intonation.fret_calibration.cache_clear()
    intonation._stored_shift.cache_clear()
    intonation.seating_force.cache_clear()
    fd_string.tune.cache_clear()
    fingering.finger_decay_db_s.cache_clear()
    wg_string.dispersion_filter.cache_clear()


@pytest.fixture
def store(tmp_path, monkeypatch):
    """A store in a fresh directory, and the process's in-memory caches emptied around the test."""
    monkeypatch.setattr(config, "CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(config, "CALIBRATION_CACHE", True)
    _forget()
    yield tmp_path / "cache"
    _forget()


def _model_and_preset():
    v = prepare(Scene.model_validate(SCENE)).voices[0]
    return v.model, engine.get_preset("steel-acoustic")


def test_a_stored_calibration_is_the_computed_one(store, monkeypatch):
    model, preset = _model_and_preset()
    computed = intonation.fret_calibration(model, preset, 7)
    assert (store / "calibrations.sqlite3").exists()
    intonation.fret_calibration.cache_clear()
    calls = []
    monkeypatch.setattr(intonation, "fret_shift",
                        lambda *a, **kw: calls.append(a) or 0.0)  # must not be needed
    assert intonation.fret_calibration(model, preset, 7) == computed
    assert calls == []
    # another fret is not in the store: computed (here by the stand-in)
    intonation.fret_calibration(model, preset, 8)
    assert calls


def test_the_key_follows_every_input():
    model, preset = _model_and_preset()
    k = calibration_store.key("fret_calibration", model, preset, 7)
    assert k != calibration_store.key("fret_calibration", model, preset, 8)
    from dataclasses import replace
    assert k != calibration_store.key("fret_calibration", replace(model, tension_n=model.tension_n
                                                                  * (1 + 1e-15)), preset, 7)
    assert k != calibration_store.key("fret_shift", model, preset, 7)


def test_a_render_is_the_same_cold_warm_and_without_the_store(store, monkeypatch):
    cold = engine.render(SCENE)
    _forget()
    warm = engine.render(SCENE)
    monkeypatch.setattr(config, "CALIBRATION_CACHE", False)
    _forget()
    off = engine.render(SCENE)
    assert np.array_equal(cold, warm) and np.array_equal(cold, off)


def test_a_process_that_finds_its_strings_stored_solves_nothing(store):
    """The strings' tuning, the seating forces and the fret calibrations of a fretted render are
    all kept: a new process that finds them computes none of them, and does not even import
    scipy's solvers (half a second of every render's start)."""
    code = (f"import sys, engine; engine.render({SCENE!r}); "
            "print([m for m in ('scipy.optimize', 'scipy.sparse') if m in sys.modules])")
    env = {**os.environ, "GUITAR_CACHE_DIR": str(store), "GUITAR_CALIBRATION_CACHE": "1"}

    def imported() -> str:
        return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True,
                              text=True, check=True).stdout.strip().splitlines()[-1]

    assert imported() == "['scipy.optimize', 'scipy.sparse']"  # a cold store: computed
    assert imported() == "[]"


def test_a_stored_finger_decay_is_the_computed_one(store, monkeypatch):
    """The waveguide's finger damping of a held note (``fingering.finger_decay_db_s``), read back
    in a process that has not computed it, without the held-note analysis."""
    preset = engine.get_preset("steel-acoustic")
    computed = fingering.finger_decay_db_s(PRESSED_STRING, preset, 2, 44100.0, 12)
    assert computed < 0.0
    fingering.finger_decay_db_s.cache_clear()
    calibration_store.reset()
    calls = []

    def analysis(*a, **kw):  # must not be needed
        calls.append(a)
        raise AssertionError("the held-note analysis ran")

    monkeypatch.setattr(statics, "held_note", analysis)
    # an int rate: the same
    assert fingering.finger_decay_db_s(PRESSED_STRING, preset, 2, 44100, 12) == computed
    assert calls == []
    with pytest.raises(AssertionError):  # another rate is another calibration
        fingering.finger_decay_db_s(PRESSED_STRING, preset, 2, 48000.0, 12)
    # the finger damping's key holds its own module's code, and is not a fret calibration's
    k = calibration_store.key("finger_decay_db_s", preset, 2, 44100.0, 12,
                              sources=fingering.SOURCES + PRESSED_STRING.sources)
    assert k != calibration_store.key("finger_decay_db_s", preset, 2, 44100.0, 12)


def test_a_waveguide_render_is_the_same_cold_warm_and_without_the_store(store, monkeypatch):
    cold = engine.render(WAVEGUIDE)
    fingering.finger_decay_db_s.cache_clear()
    warm = engine.render(WAVEGUIDE)
    monkeypatch.setattr(config, "CALIBRATION_CACHE", False)
    _forget()
    off = engine.render(WAVEGUIDE)
    assert np.max(np.abs(cold)) > 0.0
    assert np.array_equal(cold, warm) and np.array_equal(cold, off)


def test_an_unwritable_store_changes_nothing(tmp_path, monkeypatch):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a directory")
    monkeypatch.setattr(config, "CACHE_DIR", str(blocker / "cache"))
    monkeypatch.setattr(config, "CALIBRATION_CACHE", True)
    calibration_store.reset()
    intonation.fret_calibration.cache_clear()
    try:
        model, preset = _model_and_preset()
        assert calibration_store.load("anything") is None
        calibration_store.save("anything", (1.0,))
        cal = intonation.fret_calibration(model, preset, 7)
        assert np.isfinite(cal.shift_m) and cal.damping_n_s_m > 0.0
    finally:
        calibration_store.reset()
        intonation.fret_calibration.cache_clear()


def test_decimation_taps_are_firwins_to_the_bit(store):
    from scipy import signal

    from engine import output

    output._stored_taps.cache_clear()
    for factor in (2, 3, 4):
        ntaps = 24 * factor + (1 if factor % 2 else 2)
        want = signal.firwin(ntaps, 0.45 * 44100, fs=44100 * factor,
                             window=("kaiser", 9.0))[::-1]
        first = output.decimation_taps(ntaps, 44100.0, factor)  # designed and stored
        output._stored_taps.cache_clear()
        again = output.decimation_taps(ntaps, 44100.0, factor)  # read back from the store
        assert first.tobytes() == want.tobytes() == again.tobytes()
    output._stored_taps.cache_clear()


def test_on_compute_is_told_of_a_computation_only(store):
    kinds = []
    calibration_store.on_compute(kinds.append)
    try:
        calibration_store.recall("test_kind", (1, 2.5), lambda: (3.0,))
        calibration_store.recall("test_kind", (1, 2.5), lambda: (3.0,))  # stored: not computed
    finally:
        calibration_store.on_compute(None)
    calibration_store.recall("test_kind", (2, 2.5), lambda: (4.0,))  # no callback any more
    assert kinds == ["test_kind"]


def test_a_stored_dispersion_filter_is_the_fitted_one(store):
    """The waveguide's dispersion allpass of a loop, fitted once and read back to the bit; a loop
    not in the store is fitted (the CLI says so: ``on_compute``)."""
    args = (round(1.3e-4, 12), round(44100.0 / 146.83, 9), round(280.5, 6))
    kinds = []
    calibration_store.on_compute(kinds.append)
    try:
        wg_string.dispersion_filter.cache_clear()
        first = wg_string.dispersion_filter(*args)
        wg_string.dispersion_filter.cache_clear()
        again = wg_string.dispersion_filter(*args)
    finally:
        calibration_store.on_compute(None)
        wg_string.dispersion_filter.cache_clear()
    assert kinds == ["waveguide_dispersion"]
    assert first == again == wg_string._fit_dispersion(*args)
    assert first[1] >= 1 and isinstance(again[1], int)
