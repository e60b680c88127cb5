"""Compile the numba kernels, or load them from the cache, once per process.

``WARMUP_SCENES`` are tiny scenes that between them take every numba kernel path a render can
take: fingers (fret, tap, hammer-on, pull-off, slide), rigid frets and the fretboard, the
Kirchhoff-Carrier column, dampers (harmonic, palm mute), tension breakpoints (bend, vibrato),
several pickups, stereo, both built-in bodies and none, the energy terms, oversampled strings
(the decimator), and the waveguide model's sample loop.
"""

from __future__ import annotations

import time

from .rendering import render

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
    {  # the waveguide model's kernel (engine.waveguide): one type signature for every scene
        "duration": 0.01,
        "model": "waveguide",
        "events": [{"type": "fret", "time": 0.0, "string": 2, "fret": 3},
                   {"type": "strum", "time": 0.0, "spread": 0.005}],
    },
)


def warmup() -> float:
    """Compile the numba kernels, or load them from the cache (``NUMBA_CACHE_DIR``), by rendering
    ``WARMUP_SCENES``, so that the first real render of a process spends no time compiling.
    Returns the seconds it took."""
    t0 = time.perf_counter()
    for scene in WARMUP_SCENES:
        render(scene)
    return time.perf_counter() - t0
