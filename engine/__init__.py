"""Physically modelled guitar synthesis: the DAFx24 string model (Bilbao, Russo, Webb & Ducceschi
2024) with fretboard, frets, fingers and tension modulation, stepped by numba kernels.

    >>> import engine
    >>> audio = engine.render({"duration": 1.0, "events": [{"type": "pluck", "time": 0, "string": 1}]})

Also: ``blocks`` (the same audio block by block, at the fixed gain), ``frame_count`` (its length,
before rendering), ``tuned_tension`` (a preset string's tension) and ``warmup`` (load or compile
every numba kernel once per process).

Layers, low to high: ``kernels`` (the time-step loop) -> ``string`` (coefficients, tuning, geometry)
-> ``controls`` (events to control arrays) -> ``guitar`` (voices, skips, oversampling, mixing) ->
``scene`` (the validated input) -> this module (the public API) and ``output`` (encoding).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import guitar
from .guitar import FIXED_GAIN, QUALITY, RenderOptions, prepare, scene_warnings
from .output import convolve_ir
from .presets import PRESETS, Preset, get_preset
from .scene import Scene, parse_scene
from .string import tune

__all__ = ["FIXED_GAIN", "PRESETS", "QUALITY", "RenderOptions", "RenderResult", "Scene",
           "blocks", "frame_count", "get_preset", "parse_scene", "render", "scene_warnings",
           "to_output_scale", "tuned_tension", "warmup"]

PEAK_DBFS = -1.0


@dataclass
class RenderResult:
    audio: np.ndarray  # float64, (frames,) or (frames, 2), scaled as the scene's output asks
    energy_error: float  # largest relative energy-balance deviation over the strings (sec. 6.1)
    sample_rate: int
    seconds: float  # wall time of the simulation
    oversample: dict[int, int]  # string -> internal oversampling factor
    warnings: list[str] = field(default_factory=list)  # ``scene_warnings``


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
                        {v.index: v.oversample for v in eng.voices}, eng.warnings())


def blocks(scene: Scene | dict, block_frames: int = 4096, options: RenderOptions | None = None):
    """Yield the scene's audio block by block at the fixed gain (what a stream can send: it cannot
    know the peak in advance). Concatenated, equal to ``render`` with ``normalize: false``."""
    sc = parse_scene(scene)
    eng = prepare(sc, options)
    for v in eng.blocks(block_frames):
        yield v * FIXED_GAIN


def frame_count(scene: Scene | dict) -> int:
    """The number of output frames ``render`` (and ``blocks``, concatenated) returns for a scene,
    known before anything is simulated (a stream's WAV header needs it)."""
    return guitar.frame_count(parse_scene(scene))  # the rule ``prepare`` uses


def tuned_tension(preset: str | Preset, string: int, sample_rate: float = 44100.0) -> float:
    """Tension (N) that tunes string ``string`` (1 = highest) of a preset to its nominal pitch on
    the grid of ``sample_rate`` Hz: the scheme's own dispersion relation is solved for it (see
    ``engine.string.tune``), so it depends slightly on the rate.  The engine tunes each string of a
    scene this way at its internal (oversampled) rate."""
    p = get_preset(preset) if isinstance(preset, str) else preset
    if not 1 <= string <= p.n_strings:
        raise ValueError(f"string {string} outside 1..{p.n_strings} for {p.name}")
    return tune(p.strings[string - 1], p.string_length_m(string), float(sample_rate)).tension_n


# Tiny scenes that between them take every numba kernel path a render can take: fingers (fret,
# tap, hammer-on, pull-off, slide), rigid frets and the fretboard, the Kirchhoff-Carrier column,
# dampers (harmonic, palm mute), tension breakpoints (bend, vibrato), several pickups, stereo, both
# built-in bodies and none, the energy terms, and oversampled strings (the decimator).
WARMUP_SCENES: tuple[dict, ...] = (
    {
        "duration": 0.02,
        "diagnostics": True,
        "events": [
            {"type": "fret", "time": 0.0, "string": 5, "fret": 3},
            {"type": "pluck", "time": 0.001, "string": 5},
            {"type": "hammer_on", "time": 0.006, "string": 5, "fret": 5},
            {"type": "pull_off", "time": 0.012, "string": 5, "fret": 5},
            {"type": "slide", "time": 0.0, "string": 4, "from_fret": 2, "to_fret": 4,
             "duration": 0.01},
            {"type": "pluck", "time": 0.001, "string": 4, "style": "pick"},
            {"type": "tap", "time": 0.005, "string": 3, "fret": 7},
        ],
    },
    {
        "duration": 0.02,
        "guitar": {"preset": "nylon-classical"},
        "output": {"channels": 2, "pickups": [{"position": 0.9}, {"position": 0.8, "gain": 0.5}]},
        "events": [
            {"type": "harmonic", "time": 0.0, "string": 1, "fret": 12},
            {"type": "pluck", "time": 0.001, "string": 1},
            {"type": "mute", "time": 0.0, "string": 2},
            {"type": "pluck", "time": 0.001, "string": 2, "style": "slap"},
            {"type": "bend", "time": 0.002, "string": 3, "semitones": 1.0, "duration": 0.005},
            {"type": "pluck", "time": 0.0, "string": 3},
            {"type": "vibrato", "time": 0.002, "string": 6, "duration": 0.01},
            {"type": "pluck", "time": 0.0, "string": 6},
        ],
    },
    {
        "duration": 0.01,
        "guitar": {"preset": "electric"},
        "quality": "draft",
        "output": {"normalize": False},
        "events": [{"type": "strum", "time": 0.0, "spread": 0.005}],
    },
)


def warmup() -> float:
    """Compile the numba kernels, or load them from the cache (``NUMBA_CACHE_DIR``), by rendering
    ``WARMUP_SCENES``, so that the first real render of a process spends no time compiling.
    Returns the seconds it took."""
    import time

    t0 = time.perf_counter()
    for scene in WARMUP_SCENES:
        render(scene)
    return time.perf_counter() - t0
from .score import ScoreError, scene_labels, score_to_scene  # noqa: E402, I001 (engine/score)
__all__ += ["ScoreError", "scene_labels", "score_to_scene"]
