"""What a scene will cost to render, known before anything is built: a front end admits, queues or
refuses a request by it (the HTTP service does, before a worker takes the scene).

The work of a render is the time step of every simulated string: for each string with an event,
(internal steps) x (grid nodes + a fixed per-step share, larger with a finger on the string), where
the internal steps are duration x sample_rate x the string's oversampling factor. The factor and
the node count are worked out as ``engine.voice.string_model`` does, from the same stability bound
(``engine.grid``), without tuning the string on its grid (the tuning moves the node count by a few
per cent, which ``GRID_MARGIN`` covers: ``tests/engine/test_cost.py`` checks the bounds against
``prepare``) and without importing the kernels, so a process that only validates scenes can call
it.

Not in the estimate: a string whose motion has decayed stops being computed (``engine.voice``),
which makes a render cheaper than estimated; and the set-up of a scene, whose largest part is the
fret calibration of draft and standard quality (``engine.intonation``: a few static solves per
stopped fret and string, bounded by strings x frets, whatever the duration).
``benchmarks/cost.py`` prints both, set-up and stepping, against the estimate.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .grid import h_min, loss_coefficients
from .presets import Preset
from .scene import Bend, Mute, Scene, Strum, Vibrato, parse_scene

# (max_h_m, max_oversample) of each quality: ``engine.options.QUALITY``'s (which imports the
# kernels; tests/engine/test_cost.py keeps the two equal).  A string with a finger on it is
# oversampled until its grid spacing is at most max_h_m; the others run at the output rate (the
# dispersion criterion of ``oversample_for`` is met there at every rate and preset the test tries).
QUALITY_GRID = {"draft": (1.0, 8), "standard": (5.5e-3, 8), "high": (2.5e-3, 16)}
FINGER_EVENTS = ("fret", "tap", "hammer_on", "slide")  # ``engine.controls.FINGER_EVENTS``
MIN_NODES = 4  # ``engine.string.MIN_NODES``
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
    events: int  # the scene's events with strums and string-less mutes expanded per string


def expanded_event_count(scene: Scene, n_strings: int | None = None) -> int:
    """The number of single-string events the engine makes of the scene's events: a strum counts
    once per string it plucks, a mute with no ``string`` once per string of the guitar (summed
    over the tracks of a scene that has them)."""
    if scene.tracks is not None:
        return sum(expanded_event_count(t) for t in scene.track_scenes())
    n = n_strings or scene.preset().n_strings
    count = 0
    for e in scene.events:
        if isinstance(e, Strum):
            count += len(e.strings) if e.strings else n
        elif isinstance(e, Mute) and e.string is None:
            count += n
        else:
            count += 1
    return count


def _strings_used(scene: Scene, n: int) -> dict[int, list]:
    used: dict[int, list] = {}
    for e in scene.events:
        if isinstance(e, Strum):
            strings = e.strings or range(1, n + 1)
        elif getattr(e, "string", None) is None:
            strings = range(1, n + 1)
        else:
            strings = (e.string,)
        for s in strings:
            used.setdefault(s, []).append(e)
    return used


def _tension_ratio(spec, length: float, cents: float) -> float:
    # ``engine.string.tension_ratio_for_cents`` on the physical string
    stiff = math.pi**2 * spec.bending_stiffness_nm2 / length**2
    ra, f = spec.linear_density_kg_m, spec.frequency_hz
    t0 = 4.0 * length * length * ra * f * f - stiff
    f1 = f * 2.0 ** (cents / 1200.0)
    return (4.0 * length * length * ra * f1 * f1 - stiff) / t0


def string_cost(preset: Preset, string: int, events: list, rate: float, quality: str) -> StringCost:
    """The oversampling factor and node count ``prepare`` would give ``string`` for ``events``."""
    max_h, max_os = QUALITY_GRID[quality]
    spec = preset.strings[string - 1]
    length = preset.string_length_m(string)
    rmax = 1.0
    for e in events:
        if isinstance(e, Bend):
            rmax = max(rmax, _tension_ratio(spec, length, 100.0 * e.semitones))
        elif isinstance(e, Vibrato):
            rmax = max(rmax, _tension_ratio(spec, length, e.depth_cents))
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
