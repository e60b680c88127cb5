"""Physically modelled guitar synthesis: the DAFx24 string model (Bilbao, Russo, Webb & Ducceschi
2024) with fretboard, frets, fingers and tension modulation, stepped by numba kernels.

    >>> import engine
    >>> audio = engine.render({"duration": 1.0, "events": [{"type": "pluck", "time": 0, "string": 1}]})

Also: ``blocks`` (the same audio block by block, at the fixed gain), ``frame_count`` (its length,
before rendering), ``estimate_cost`` (the work of a render, known from the scene alone),
``tuned_tension`` (a preset string's tension), ``truncate`` (a scene's JSON form cut at N
seconds) and ``warmup`` (load or compile every numba kernel
once per process); ``Session`` plays a guitar live, event by event, block by block
(``engine.live``).

Layers, each knowing only those below it (docs/architecture.md draws them):

    presets      instruments in physical units                       (numpy)
    effect_specs the effects a track may use, in units                 (pydantic)
    scene        the validated input: tracks, events, output, quality, limits (pydantic; knows
                 presets, effect_specs)
    live_events  live play messages: a session's opening and its events without time (schema)
    grid         the scheme's loss coefficients and stability bound       (plain arithmetic)
    cost         what a scene will cost to render, before anything is built (knows scene, grid)
    kernels      the numba time-step loop of one string
    string       one string's grid, coefficients, tuning and geometry (knows kernels, presets)
    controls     events -> one string's control arrays                 (knows scene, kernels)
    calibration_store  fret calibrations kept on disk across processes  (knows config)
    intonation   fret calibration and seating forces                   (knows string, controls)
    options      quality levels and render switches
    output       decimation, pickups, pan, body, output scale
    voice        one string of a scene: state across blocks, energy bookkeeping
    playability  warnings: what may not sound as the player means it
    guitar       the voices of one instrument, block by block
    waveguide/   the same instrument as digital waveguides (Evangelista & Eckerholm 2010; knows
                 what guitar knows)
    effects      a track's effects chain (pedalboard), state kept across blocks
    mix          a scene of tracks: a guitar per track, panned, through effects, mixed
    live         an open-ended session: events pushed as played, blocks pulled (``Session``)
    rendering    the public functions: scene in, audio out
    precompile   compile or load every kernel once per process (``warmup``)

Beside them, knowing only the scene's JSON form and the presets:

    score/       scores in (Guitar Pro 3-5, MIDI) -> scenes, fingering, JAMS labels of any scene

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
    "QUALITY": "options",
    "Quality": "options",
    "RenderOptions": "options",
    "RenderResult": "rendering",
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
    "ScoreError": "score",
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
