"""The engine's front door: a scene in, audio out.

``render`` validates the scene (``engine.scene``), prepares its tracks (``engine.mix.prepare``: a
guitar per track, ``engine.fd.instrument.prepare``: a voice per string that needs simulating) and writes
the mix's blocks into the output array; ``blocks`` yields them as they are computed, at the fixed
gain a stream needs, and holds nothing but the current block (a song of any length streams in
bounded memory).  Every front end (Python, the HTTP service's workers, a command line) goes
through these two functions.  ``jobs``: the threads a render computes its strings on
(``engine.mix``); the samples are the same for any number.  With ``stems`` both also give each
string's own signal (``engine.mix``: before pan, body and effects, at the mix's gain; summed, the
dry mix).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .mix import Mix, prepare
from .options import RenderOptions
from .output import FIXED_GAIN, convolve_ir, largest_magnitude, output_gain
from .scene import Scene, Stem, parse_scene

log = logging.getLogger("engine")


class RenderCancelled(Exception):
    """``render_result``'s ``cancelled`` said stop: the render ended between two blocks."""


@dataclass
class RenderResult:
    audio: np.ndarray  # float64, (frames,) or (frames, 2), scaled as the scene's output asks
    # largest relative energy-balance deviation over the strings (sec. 6.1); None when the render
    # ran without diagnostics (the energy terms were not computed)
    energy_error: float | None
    sample_rate: int
    seconds: float  # wall time of the simulation
    oversample: dict[int, int]  # string -> internal oversampling factor (largest over tracks)
    warnings: list[str] = field(default_factory=list)  # ``engine.fd.playability.scene_warnings``
    # with ``stems``: (frames, len(stem_layout)) at the audio's gain, and what each column is
    stems: np.ndarray | None = None
    stem_layout: list[Stem] = field(default_factory=list)
    gain: float = 1.0  # samples per m/s of pickup velocity: the audio's (and the stems') scale


def render(scene: Scene | dict, diagnostics: bool | None = None,
           options: RenderOptions | None = None, impulse_response: np.ndarray | None = None,
           jobs: int = 1):
    """Render a scene. Returns the audio array, shape (frames,) for mono or (frames, 2) for
    stereo, or a ``RenderResult`` when diagnostics are asked for (by the argument or by the
    scene's ``diagnostics`` field when the argument is omitted).

    ``impulse_response``: a body or room response (samples at the scene's rate) convolved with the
    output instead of the built-in body (scipy FFT convolution).  ``jobs``: threads (``Mix``).
    """
    sc = parse_scene(scene)
    diag = sc.diagnostics if diagnostics is None else diagnostics
    if diag != sc.diagnostics:
        sc = sc.model_copy(update={"diagnostics": diag})
    result = render_result(sc, options, impulse_response, jobs)
    return result if diag else result.audio


def render_result(scene: Scene | dict, options: RenderOptions | None = None,
                  impulse_response: np.ndarray | None = None, jobs: int = 1,
                  stems: bool | None = None,
                  on_stems: Callable[[np.ndarray], None] | None = None,
                  cancelled: Callable[[], bool] | None = None) -> RenderResult:
    """Render a scene and return the audio with what is known of the render: its warnings, wall
    time and oversampling, and the energy balance when the scene asks for diagnostics.
    ``stems`` (default: the scene's ``output.stems``): each string's signal too, scaled by the
    audio's gain (``RenderResult.stems``; a user ``impulse_response``, like the body, acts on the
    mix only).  Under ``normalize`` that one gain puts the loudest of the mix and the stems at
    ``PEAK_DBFS``, so that no stem clips (a string can peak above a mix its body, pan or
    effects soften): with stems the mix may come quieter than without.  ``on_stems``: instead
    of holding them, hand each block of stems (m/s, before the output gain: times
    ``RenderResult.gain`` they are the held ones) to this function as it is computed (a long
    song's stems written to files in bounded memory).  ``cancelled``: asked after every block;
    when it returns true the render stops there (``RenderCancelled``: whoever wanted the audio
    has gone)."""
    sc = parse_scene(scene)
    with_stems = on_stems is not None or (sc.output.stems if stems is None else stems)
    t0 = time.perf_counter()
    if impulse_response is not None:
        sc = sc.model_copy(update={"output": sc.output.model_copy(update={"body": "none"})})
    mix = prepare(sc, options, jobs)
    layout = mix.stems() if with_stems else []
    # the blocks are written into the output as they come: no more than the output is held
    vel = np.zeros((mix.frames, 2) if sc.output.channels == 2 else mix.frames)
    strings = np.zeros((mix.frames, len(layout))) if with_stems and on_stems is None else None
    stems_peak = 0.0
    for item in mix.blocks(stems=with_stems):
        blk, string_blk = item if with_stems else (item, None)
        at = mix.frame - len(blk)
        vel[at:mix.frame] = blk
        if string_blk is not None:
            stems_peak = max(stems_peak, largest_magnitude(string_blk))
        if on_stems is not None:
            on_stems(string_blk)
        elif strings is not None:
            strings[at:mix.frame] = string_blk
        if cancelled is not None and cancelled():
            raise RenderCancelled(f"stopped after {mix.frame} of {mix.frames} frames")
    if impulse_response is not None:
        vel = convolve_ir(vel, impulse_response)
    seconds = time.perf_counter() - t0
    # one gain for the mix and its stems: the loudest of them sets it (``to_output_scale``'s
    # arithmetic; times 1.0 for silence leaves the samples as they are)
    normalize = sc.output.normalize
    peak = max(largest_magnitude(vel), stems_peak) if normalize else 0.0
    gain = output_gain(peak, normalize)
    audio = np.multiply(vel, gain, out=vel)
    if strings is not None:
        strings *= gain
    return RenderResult(audio, mix.energy_error() if sc.diagnostics else None, sc.sample_rate,
                        seconds, mix.oversample(), advice(mix), strings, layout, gain)


def advice(mix: Mix) -> list[str]:
    """``mix.warnings()``, which are advice: if working them out fails, the audio still comes,
    without them (the failure is logged)."""
    try:
        return mix.warnings()
    except Exception:
        log.exception("working out the scene's warnings failed; the render goes without them")
        return []


class Blocks:
    """The scene's audio block by block at the fixed gain (what a stream can send: it cannot know
    the peak in advance); concatenated, equal to ``render`` with ``normalize: false``.
    ``warnings`` are known once the tracks are prepared, before the first block.  With
    ``stems``, each item is a pair (mix block, stems block), the stems at the same gain, and
    ``stem_layout`` says what their columns are (``engine.Stem``)."""

    def __init__(self, scene: Scene | dict, block_frames: int = 4096,
                 options: RenderOptions | None = None, raw: bool = False, jobs: int = 1,
                 stems: bool = False):
        mix = prepare(parse_scene(scene), options, jobs)
        self.warnings: list[str] = advice(mix)
        self.stem_layout: list[Stem] = mix.stems() if stems else []
        self._blocks = mix.blocks(block_frames, stems)
        self._raw = raw
        self._stems = stems

    def __iter__(self):
        return self

    def __next__(self):
        item = next(self._blocks)
        if self._raw:
            return item
        if self._stems:
            return item[0] * FIXED_GAIN, item[1] * FIXED_GAIN
        return item * FIXED_GAIN


def blocks(scene: Scene | dict, block_frames: int = 4096,
           options: RenderOptions | None = None, raw: bool = False, jobs: int = 1,
           stems: bool = False) -> Blocks:
    """An iterable of the scene's audio blocks at the fixed gain (``Blocks``); ``raw``: the
    pickup velocity itself (m/s), before any gain, for a caller that scales the whole signal as
    ``render`` does (``to_output_scale``) once it has seen every block; ``jobs``: threads
    (``engine.mix``); ``stems``: (mix, stems) pairs."""
    return Blocks(scene, block_frames, options, raw, jobs, stems)
