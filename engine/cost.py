"""What a scene will cost to render, known before anything is built: a front end admits, queues or
refuses a request by it (the HTTP service does, before a worker takes the scene).

The work of a render is the time step of every simulated string: for each string with an event,
(internal steps) x (grid nodes + a fixed per-step share, larger with a finger on the string), where
the internal steps are duration x sample_rate x the string's oversampling factor. The factor and
the node count are worked out as ``engine.fd.voice.string_model`` does, from the same stability bound
(``engine.fd.grid``), without tuning the string on its grid (the tuning moves the node count by a few
per cent, which ``GRID_MARGIN`` covers: ``tests/engine/test_cost.py`` checks the bounds against
``prepare``) and without importing the kernels, so a process that only validates scenes can call
it.

Not in the estimate: a string whose motion has decayed stops being computed (``engine.fd.voice``),
which makes a render cheaper than estimated; and the set-up of a scene, whose largest part is the
fret calibration of draft and standard quality (``engine.fd.intonation``: a few static solves per
stopped fret and string, bounded by strings x frets, whatever the duration).
``benchmarks/cost.py`` prints both, set-up and stepping, against the estimate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import partial

from .fd.grid import MIN_NODES, h_min
from .losses import loss_coefficients
from .options import QUALITY
from .performance import FINGER_EVENTS, max_tension_ratio, strings_of
from .presets import Preset
from .scene import Scene, parse_scene

# A string with a finger on it is oversampled until its grid spacing is at most its quality's
# ``max_h_m`` (``engine.options.QUALITY``); the others run at the output rate (the dispersion
# criterion of ``oversample_for`` is met there at every rate and preset the test tries).
# The per-step work that does not grow with the grid (the step's bookkeeping, the pickup, the
# decimator), in nodes' worth: measured by ``benchmarks/cost.py`` (a draft string of 30 nodes
# costs about as much per step as 30 + this many).
STEP_OVERHEAD_NODES = 40
# ... and of a string with a finger on it (contacts with the finger and the frets), on top
FINGER_STEP_NODES = 150
# The tuned grid can have a few per cent fewer nodes than the stability bound at the physical
# stiffness gives (the dispersion compensation raises the stiffness, which coarsens it), and so
# need the next factor up: the estimate asks for this much finer a spacing, so that it never counts
# a string below its real grid (tests/engine/test_cost.py: per string at least the real work, per
# scene at most 1.3 times it).
GRID_MARGIN = 0.95


@dataclass(frozen=True)
class StringCost:
    string: int
    oversample: int
    nodes: int
    fingered: bool


@dataclass(frozen=True)
class Cost:
    """``work``: node-steps (see the module docstring); ``per_second``: work per second of audio."""

    work: float
    per_second: float
    strings: tuple[StringCost, ...]
    events: int  # the scene's events with strums and string-less mutes and damps expanded per string


def expanded_event_count(scene: Scene, n_strings: int | None = None) -> int:
    """The number of single-string events the engine makes of the scene's events: a strum counts
    once per string it plucks, a mute or damp with no ``string`` once per string of the guitar
    (``performance.strings_of``; summed over the tracks of a scene that has them)."""
    if scene.tracks is not None:
        return sum(expanded_event_count(t) for t in scene.track_scenes())
    n = n_strings or scene.preset().n_strings
    return sum(len(strings_of(e, n)) for e in scene.events)


def _strings_used(scene: Scene, n: int) -> dict[int, list]:
    used: dict[int, list] = {}
    for e in scene.events:
        for s in strings_of(e, n):
            used.setdefault(s, []).append(e)
    return used


def _tension_ratio(spec, length: float, cents: float) -> float:
    # ``engine.fd.string.tension_ratio_for_cents`` on the physical string
    stiff = math.pi**2 * spec.bending_stiffness_nm2 / length**2
    ra, f = spec.linear_density_kg_m, spec.frequency_hz
    t0 = 4.0 * length * length * ra * f * f - stiff
    f1 = f * 2.0 ** (cents / 1200.0)
    return (4.0 * length * length * ra * f1 * f1 - stiff) / t0


def string_cost(preset: Preset, string: int, events: list, rate: float, quality: str) -> StringCost:
    """The oversampling factor and node count ``prepare`` would give ``string`` for ``events``."""
    q = QUALITY[quality]
    max_h, max_os = q.max_h_m, q.max_oversample
    spec = preset.strings[string - 1]
    length = preset.string_length_m(string)
    rmax = max_tension_ratio(events, partial(_tension_ratio, spec, length))
    tension = spec.linear_density_kg_m * (2.0 * length * spec.frequency_hz) ** 2
    _, sigma1 = loss_coefficients(spec, tension)
    fingered = any(e.type in FINGER_EVENTS for e in events)
    for os_ in range(1, max_os + 1):
        k = 1.0 / (rate * os_)
        hmin = h_min(k, tension * rmax, spec.linear_density_kg_m, spec.bending_stiffness_nm2,
                     sigma1)
        nodes = max(int(length / hmin), MIN_NODES)
        if not fingered or length / nodes <= GRID_MARGIN * max_h:
            break
    return StringCost(string, os_, nodes, fingered)


def estimate_cost(scene: Scene | dict) -> Cost:
    """The work of rendering ``scene`` (a ``Cost``), from its size alone."""
    sc = parse_scene(scene)
    rate = float(sc.sample_rate)
    strings: tuple[StringCost, ...] = ()
    for single in sc.track_scenes():  # each track's guitar (the waveguide's are costed alike)
        preset = single.preset()
        strings += tuple(string_cost(preset, s, evs, rate, sc.quality)
                         for s, evs in sorted(_strings_used(single, preset.n_strings).items()))
    per_second = sum(rate * c.oversample * (c.nodes + STEP_OVERHEAD_NODES
                                            + (FINGER_STEP_NODES if c.fingered else 0))
                     for c in strings)
    return Cost(per_second * sc.duration, per_second, strings, expanded_event_count(sc))
