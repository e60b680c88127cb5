"""Physically modelled guitar synthesis by two models behind one instrument interface: the DAFx24
finite-difference string (Bilbao, Russo, Webb & Ducceschi 2024) with fretboard, frets, fingers and
tension modulation, stepped by numba kernels (``fd/``), and the digital waveguide of Evangelista &
Eckerholm 2010 (``waveguide/``).

    >>> import engine
    >>> audio = engine.render({"duration": 1.0, "events": [{"type": "pluck", "time": 0, "string": 1}]})

Also: ``blocks`` (the same audio block by block, at the fixed gain), ``frame_count`` (its length,
before rendering), ``estimate_cost`` (the work of a render, known from the scene alone),
``tuned_tension`` (a preset string's tension), ``truncate`` (a scene's JSON form cut at N seconds)
and ``warmup`` (load or compile every numba kernel once per process); ``Session`` plays a guitar
live, event by event, block by block (``engine.live``).

Layers, each knowing only those below it (docs/architecture.md draws them; tests/test_layers.py
reads every module's imports, inside functions too):

    config       numba flags, the cache folders, calling a compiled kernel
    presets      instruments in physical units                       (numpy)
    effect_specs the effects a track may use, in units                 (pydantic)
    scene        the validated input: tracks, events, output, quality, limits (pydantic)
    live_events  live play messages: a session's opening and its events without time (schema)
    analysis     measurements of rendered audio (pitch, levels) for tests and benchmarks
    losses       a string's loss coefficients from its two decay times (plain arithmetic)
    performance  what the player does, the same for every model: strum, mute-all, finger
                 position, the hands' contacts, bend and vibrato curves, a scene cut short
    options      quality levels and render switches (plain data: names, no kernel constants)
    fd.grid      the finite-difference stability bound (plain arithmetic)
    cost         what a scene will cost to render, before anything is built
    score/       scores in (Guitar Pro 3-8, MusicXML, MIDI) -> scenes, fingering, JAMS labels of any
                 scene (knows only the schema, the presets and performance)
    calibration_store  calibrations kept on disk across processes
    output       decimation, pickups, pan, body, output scale
    instrument   the interface both models implement, and what they share (the block loop,
                 pickups and body, the frame count)
    statics      the face of the pressed string's statics both models use (seating force, a
                 held note's decay): ``fd.statics`` computes them, ``models`` hands them over
    fd/          the finite-difference model: kernels/, string, controls, intonation, statics,
                 voice, playability, instrument (its modules in that order)
    waveguide/   the digital-waveguide model (neither model reaches the other's package)
    models       the one map from a scene's ``model`` to its instrument, and from the fd
                 statics to the waveguide
    effects      a track's effects chain (pedalboard), state kept across blocks
    mix          a scene of tracks: an instrument per track, panned, through effects, mixed
    live         an open-ended session: events pushed as played, blocks pulled (``Session``)
    rendering    the public functions: scene in, audio out
    precompile   compile or load every kernel once per process (``warmup``)
    testing/     naive references and shared measurements for tests and benchmarks

The schema layer (``Scene``, ``parse_scene``, ``frame_count``, presets) is imported eagerly and
loads no numerics, so a front end that only validates scenes never imports numba; the rest is
imported on first use.
"""

from __future__ import annotations

import importlib

from .presets import PRESETS, Preset, get_preset
from .scene import MODELS, ModelName, QualityName, Scene, frame_count, parse_scene

# name -> module that defines it, imported on first access (PEP 562)
_LAZY = {
    "FIXED_GAIN": "output",
    "to_output_scale": "output",
    "largest_magnitude": "output",
    "output_gain": "output",
    "Stem": "scene",
    "stems_index": "scene",
    "QUALITY": "options",
    "Quality": "options",
    "RenderOptions": "options",
    "RenderResult": "rendering",
    "RenderCancelled": "rendering",
    "render": "rendering",
    "render_result": "rendering",
    "blocks": "rendering",
    "scene_warnings": "fd.playability",
    "estimate_cost": "cost",
    "expanded_event_count": "cost",
    "tuned_tension": "fd.string",
    "truncate": "performance",
    "warmup": "precompile",
    "WARMUP_SCENES": "precompile",
    # scores in, labels out (engine/score: Guitar Pro, MIDI, JAMS)
    "score_to_scene": "score",
    "scene_labels": "score",
    "save_labels": "score",
    "ScoreError": "score",
    "SCORE_SUFFIXES": "score",
    "group_warnings": "score",
    "select_warnings": "score",
    "WARNING_MODES": "score",
    "kernels_cached": "precompile",
    "compile_seconds": "precompile",
    "prepare_kernels": "precompile",
    "KERNEL_SCENES": "precompile",
    "Session": "live",
    "LiveError": "live_events",
    "parse_live_open": "live_events",
    "parse_live_event": "live_events",
}

__all__ = ["MODELS", "ModelName", "PRESETS", "Preset", "QualityName", "Scene", "frame_count",
           "get_preset", "parse_scene", *_LAZY]


def __getattr__(name: str):
    if name in _LAZY:
        value = getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
        globals()[name] = value  # later look-ups skip this function
        return value
    raise AttributeError(f"module 'engine' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_LAZY})
