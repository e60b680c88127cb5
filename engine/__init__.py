"""Physically modelled guitar synthesis: the DAFx24 string model (Bilbao, Russo, Webb & Ducceschi
2024) with fretboard, frets, fingers and tension modulation, stepped by numba kernels.

    >>> import engine
    >>> audio = engine.render({"duration": 1.0, "events": [{"type": "pluck", "time": 0, "string": 1}]})

Layers, low to high: ``kernels`` (the time-step loop) -> ``string`` (coefficients, tuning, geometry)
-> ``controls`` (events to control arrays) -> ``guitar`` (voices, skips, oversampling, mixing) ->
``scene`` (the validated input) -> this module (the public API) and ``output`` (encoding).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .guitar import FIXED_GAIN, QUALITY, RenderOptions, prepare
from .output import convolve_ir
from .presets import PRESETS, get_preset
from .scene import Scene, parse_scene

__all__ = ["FIXED_GAIN", "PRESETS", "QUALITY", "RenderOptions", "RenderResult", "Scene",
           "blocks", "get_preset", "parse_scene", "render", "to_output_scale"]

PEAK_DBFS = -1.0


@dataclass
class RenderResult:
    audio: np.ndarray  # float64, (frames,) or (frames, 2), scaled as the scene's output asks
    energy_error: float  # largest relative energy-balance deviation over the strings (sec. 6.1)
    sample_rate: int
    seconds: float  # wall time of the simulation
    oversample: dict[int, int]  # string -> internal oversampling factor


def to_output_scale(velocity: np.ndarray, normalize: bool) -> np.ndarray:
    """Pickup velocity (m/s) -> samples: peak at -1 dBFS, or the fixed gain ``FIXED_GAIN``."""
    if not normalize:
        return velocity * FIXED_GAIN
    peak = float(np.max(np.abs(velocity))) if velocity.size else 0.0
    if peak == 0.0:
        return velocity.copy()
    return velocity * (10.0 ** (PEAK_DBFS / 20.0) / peak)


def render(scene: Scene | dict, diagnostics: bool | None = None,
           options: RenderOptions | None = None, impulse_response: np.ndarray | None = None):
    """Render a scene. Returns the audio array, shape (frames,) for mono or (frames, 2) for
    stereo, or a ``RenderResult`` when diagnostics are asked for (by the argument or by the
    scene's ``diagnostics`` field when the argument is omitted).

    ``impulse_response``: a body or room response (samples at the scene's rate) convolved with the
    output instead of the built-in body (scipy FFT convolution).
    """
    import time

    sc = parse_scene(scene)
    diag = sc.diagnostics if diagnostics is None else diagnostics
    if diag != sc.diagnostics:
        sc = sc.model_copy(update={"diagnostics": diag})
    t0 = time.perf_counter()
    if impulse_response is not None:
        sc = sc.model_copy(update={"output": sc.output.model_copy(update={"body": "none"})})
    eng = prepare(sc, options)
    parts = list(eng.blocks())
    vel = np.concatenate(parts) if parts else np.zeros(0)
    if impulse_response is not None:
        vel = convolve_ir(vel, impulse_response)
    seconds = time.perf_counter() - t0
    audio = to_output_scale(vel, sc.output.normalize)
    if not diag:
        return audio
    return RenderResult(audio, eng.energy_error(), sc.sample_rate, seconds,
                        {v.index: v.oversample for v in eng.voices})


def blocks(scene: Scene | dict, block_frames: int = 4096, options: RenderOptions | None = None):
    """Yield the scene's audio block by block at the fixed gain (what a stream can send: it cannot
    know the peak in advance). Concatenated, equal to ``render`` with ``normalize: false``."""
    sc = parse_scene(scene)
    eng = prepare(sc, options)
    for v in eng.blocks(block_frames):
        yield v * FIXED_GAIN
