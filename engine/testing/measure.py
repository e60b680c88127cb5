"""Measurements that read the engine's state while it renders, not only its audio.

Each is asserted on by a test and printed as a table by a benchmark (named beside it), so that the
two cannot disagree:

- ``board_depth``: how deep a tapped string sinks below the fretboard, checked at every internal
  step (``tests/engine/test_stress.py``; ``benchmarks/accuracy.py``);
- ``resting_share`` / ``holds``: whether a fretted string rests on its fret (its rigid constraint
  in the kernel's active set) (``tests/engine/test_intonation.py``; ``benchmarks/seating.py``);
- ``quiet_share``, ``held_share``, ``held_steps``: the share of steps the quiet and the held runs
  take, and ``kc_skip_pitch_shift``: the pitch the Kirchhoff-Carrier skip moves
  (``tests/engine/test_skips.py``, ``tests/engine/test_held.py``; ``benchmarks/skips.py``).
"""

from __future__ import annotations

import time
import tracemalloc

import numpy as np

import engine
from engine import QUALITY, RenderOptions, Scene
from engine.analysis import cents, spectrum_peak
from engine.fd.instrument import prepare  # the prepared strings: their state is what these measure
from engine.testing.scenes import SR, scene, tap
from engine.testing.scenes import fret as fret_at
from engine.testing.scenes import pluck as pluck_at

# ---- the fretboard ------------------------------------------------------------------------------


def board_depth(velocity: float, oversample: int | None, rule: str = "joint",
                force: float = 10.0, fret: int = 12, string: int = 1, rigid_board: bool = True,
                quality: str = "standard") -> tuple[float, float]:
    """A tap at ``fret`` of ``string``, stepped one internal step at a time (``oversample`` None:
    the quality's): the deepest any node goes below the fretboard (m; negative if none reaches
    it) and, on the Hertzian board, the static depth of the whole force on one grid cell (m; 0
    on the rigid board)."""
    sc = Scene.model_validate(scene([tap(string, fret, force=force, velocity=velocity)], 0.015,
                                    quality=quality))
    eng = prepare(sc, RenderOptions(oversample=oversample, gamma_rule=rule,
                                    rigid_board=rigid_board))
    v = eng.voices[0]
    c = v.coefs
    deepest = -np.inf
    for _ in range(round(sc.duration * SR) * v.oversample):
        v.run(1)
        deepest = max(deepest, float(np.max(v.geom.board - v.state.u[2:c.n + 1])))
    static = (force / (c.board_k * c.h)) ** (1.0 / c.board_alpha) if c.board_k > 0.0 else 0.0
    return deepest, static


# ---- a fretted note holds ---------------------------------------------------------------------

HOLD_SHARE = 0.95  # a note holds when the string rests on its fret at this share of the checks
CHECK_FRAMES = 64  # one check every this many output samples


def seating_scene(preset_name: str, string: int, fret: int, force: float | None, pluck: float,
                  extra: tuple = (), duration: float = 1.0) -> Scene:
    """A finger behind ``fret`` pressing with ``force`` (None: the engine's default), a pluck of
    ``pluck`` N at 0.05 s and the ``extra`` events, mono at the fixed gain, no body."""
    events = [fret_at(string, fret, force=force), pluck_at(string, 0.05, force=pluck), *extra]
    return Scene.model_validate(scene(
        events, duration, guitar={"preset": preset_name},
        output={"body": "none", "channels": 1, "normalize": False}))


def resting_share(preset_name: str, quality: str, string: int, fret: int, force: float | None,
                  pluck: float, extra: tuple = (), start: float = 0.2,
                  duration: float = 1.0) -> float:
    """Share of the checks from ``start`` to ``duration`` seconds at which the string rests on
    ``fret`` (its rigid constraint active), the finger pressing with ``force`` (None: the
    default, ``intonation.press_force``), a pluck of ``pluck`` N at 0.05 s and the ``extra``
    events (a bend, say)."""
    sc = seating_scene(preset_name, string, fret, force, pluck, extra, duration)
    eng = prepare(sc, RenderOptions(quality=QUALITY[quality], skip_decayed=False))
    voice = eng.voices[0]
    checks = []
    done = 0
    for block in eng.blocks(CHECK_FRAMES):
        done += len(block)
        if done >= start * SR:
            checks.append(bool(voice.state.fret_active[fret - 1]))
    return float(np.mean(checks))


def holds(preset_name: str, quality: str, string: int, fret: int, force: float,
          pluck: float) -> bool:
    return resting_share(preset_name, quality, string, fret, force, pluck) >= HOLD_SHARE


# ---- the skips --------------------------------------------------------------------------------


def quiet_share(force: float, seconds: float) -> dict[int, float]:
    """Share of each string's steps that took the quiet run (``kernels._quiet_run``) in an open
    strum of ``force`` N, quality 'standard'."""
    sc = {"duration": seconds, "events": [
        {"type": "pluck", "time": 0.02 * i, "string": 6 - i, "force": force} for i in range(6)]}
    eng = prepare(Scene.model_validate(sc), RenderOptions(skip_decayed=False))
    for _ in eng.blocks():
        pass
    return {v.index: int(v.state.run_steps[0]) / v.step for v in eng.voices}


def held_share(scene: dict) -> dict[int, float]:
    """Share of each string's steps that took the held run (``kernels._held_run``)."""
    eng = prepare(Scene.model_validate(scene), RenderOptions(skip_decayed=False))
    for _ in eng.blocks():
        pass
    return {v.index: int(v.state.run_steps[1]) / v.step for v in eng.voices}


def held_steps(eng) -> tuple[int, int]:
    """(steps the held run took, all steps) over the strings of a rendered engine."""
    return (sum(int(v.state.run_steps[1]) for v in eng.voices),
            sum(v.step for v in eng.voices))


def kc_skip_pitch_shift(string: int, force: float = 2.0, seconds: float = 2.0,
                        tolerance: float | None = None) -> tuple[float, bool]:
    """Cents between the fundamental of one open-string pluck rendered with the Kirchhoff-Carrier
    skip (``tolerance``; None: the quality's) and without it, measured over 0.5 s to the end, and
    whether the two renders differ at all."""
    sc = Scene.model_validate({"duration": seconds, "events": [
        {"type": "pluck", "time": 0.0, "string": string, "force": force}]})
    outs = []
    for tol in (tolerance, 0.0):
        eng = prepare(sc, RenderOptions(kc_tolerance=tol))
        outs.append(np.concatenate(list(eng.blocks())))
    sr = sc.sample_rate
    f0 = eng.voices[0].model.spec.frequency_hz
    late = slice(int(0.5 * sr), None)
    shift = float(cents(spectrum_peak(outs[0][late], sr, f0), spectrum_peak(outs[1][late], sr, f0)))
    return shift, not np.array_equal(outs[0], outs[1])


def stream_peak(scene: dict) -> tuple[float, float, int]:
    """(wall seconds, peak traced bytes, output bytes) of streaming the scene's blocks."""
    tracemalloc.start()
    t0 = time.perf_counter()
    frames = 0
    for block in engine.blocks(scene):
        frames += len(block)
        assert np.all(np.isfinite(block))
    seconds = time.perf_counter() - t0
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return seconds, peak, frames * 2 * 8
