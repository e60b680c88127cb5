"""What the player does, the same for every model: how a strum spreads over the strings, that a
mute or damp without a string acts on all of them, where a finger stops a string, the hands'
contacts in units of the string's impedance, the breakpoints of bends and vibrato, and a scene cut
short.  Plain Python on the scene schema (no numerics library), so that both models, a live
session, the score importers and labels, the cost estimate and the command line read one rule.

How each model turns these gestures into forces: ``engine.fd.controls`` (the finite-difference
model's control arrays), ``engine.waveguide.controls`` (the waveguide's timeline).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any

import numpy as np

from .presets import Preset, StringSpec
from .scene import Bend, Damp, Mute, Pluck, Scene, Strum, Vibrato

# events that put a finger on the string (a harmonic touches it without pressing)
FINGER_EVENTS = ("fret", "tap", "hammer_on", "slide")
FINGER_BEHIND = 0.3  # of the spacing between fret q-1 and fret q
MAX_FINGERS = 4  # fingers of the fretting hand on one string at once (hammer-ons add them)

# style -> (pulse length s, direction): a pick releases faster than a fingertip; a slap drives
# the string into the frets, a pop pulls it away so that it snaps back onto them.
PLUCK_STYLES = {
    "finger": (1e-3, 1.0),
    "pick": (3e-4, 1.0),
    "slap": (5e-4, -1.0),
    "pop": (2e-3, 1.0),
}

# The hands' contacts, as dampers R in units of the string's wave impedance sqrt(T rho A):
# a harmonic's light touch (at one point: near the R = 2 sqrt(T rho A) that absorbs most of a
# passing wave), the palm of a mute at amount 1 (spread over ``PALM_WIDTH_M``)
HARMONIC_DAMPING = 2.0
PALM_DAMPING = 0.8
PALM_WIDTH_M = 0.02
# A damp lays the relaxed fretting hand's four fingertips on the string, about a fret apart, from
# where the fretting finger was towards the bridge: four point dampers, each of R = 1 x sqrt(T rho
# A).  One touch absorbs at most half the energy of a wave passing it (at R = 2 sqrt(T rho A));
# four in a row take most of it in one pass.  ``tests/engine/test_damp.py`` prints the time to
# -60 dB of every string of the steel preset, open and fretted (docs/engine.md quotes them).
DAMP_DAMPING = 1.0  # x sqrt(T rho A) per finger
DAMP_FINGERS = 4
DAMP_SPACING_M = 0.035
DAMP_OPEN_FRET = 5  # where the fretting hand touches an open string

VIBRATO_POINTS_PER_CYCLE = 32


def finger_x_m(preset: Preset, fret: int, spec: StringSpec | None = None) -> float:
    """Metres from the nut of a finger stopping ``fret`` (just behind it) on string ``spec``
    (``Preset.fret_x_m``: its nut compensation; None: an uncompensated nut)."""
    xq = preset.fret_x_m(fret, spec)
    return float(xq - FINGER_BEHIND * (xq - preset.fret_x_m(fret - 1, spec)))


# ---- which strings an event acts on ---------------------------------------------------------

def strum_times(time: float, strings: Iterable[int] | None, direction: str, spread: float,
                n_strings: int) -> list[tuple[int, float]]:
    """(string, time) of each pluck of a strum across ``strings`` (None or empty: all
    ``n_strings``): from the low string up for ``down``, down from the high one for ``up``, the
    ``spread`` divided evenly between the first pluck and the last."""
    order = sorted(strings or range(1, n_strings + 1), reverse=direction == "down")
    dt = spread / max(len(order) - 1, 1)
    return [(s, time + i * dt) for i, s in enumerate(order)]


def strum_plucks(e: Strum, n_strings: int) -> list[Pluck]:
    """The plucks a strum makes (``strum_times``), with its force, position and style."""
    return [Pluck(time=t, string=s, force=e.force, position=e.position, style=e.style)
            for s, t in strum_times(e.time, e.strings, e.direction, e.spread, n_strings)]


def acts_on_all(e: Any) -> bool:
    """A mute or damp without a string: the player's hand acts on every string."""
    return isinstance(e, Mute | Damp) and e.string is None


def strings_of(e: Any, n_strings: int) -> list[int]:
    """The strings an event acts on: a strum's, every string for a mute or damp without one,
    else its own."""
    if isinstance(e, Strum):
        return list(e.strings or range(1, n_strings + 1))
    if acts_on_all(e):
        return list(range(1, n_strings + 1))
    return [e.string]


def per_string(e: Any, n_strings: int) -> list:
    """A scene event as the single-string events it makes: a strum's plucks, a mute or damp
    without a string copied to every string, else the event itself."""
    if isinstance(e, Strum):
        return strum_plucks(e, n_strings)
    if acts_on_all(e):
        return [e.model_copy(update={"string": s}) for s in range(1, n_strings + 1)]
    return [e]


def expand(scene: Scene, n_strings: int) -> list:
    """The scene's events with strums split into plucks (those before the scene's end) and
    string-less mutes and damps per string."""
    out = []
    for e in scene.events:
        if isinstance(e, Strum):
            out += [p for p in strum_plucks(e, n_strings) if p.time < scene.duration]
        else:
            out += per_string(e, n_strings)
    return out


def events_by_string(scene: Scene, n_strings: int) -> dict[int, list]:
    """The single-string events of every string 1..``n_strings`` (``expand``, done once), each
    string's in time order (a stable sort: events at one time keep the scene's order)."""
    out: dict[int, list] = {s: [] for s in range(1, n_strings + 1)}
    for e in expand(scene, n_strings):
        if e.string in out:
            out[e.string].append(e)
    for events in out.values():
        events.sort(key=lambda e: e.time)
    return out


def events_on(scene: Scene, n_strings: int, string: int) -> list:
    """The single-string events of ``string`` (``expand``), in time order.  For every string of
    a scene, ``events_by_string`` expands it once instead of once a string."""
    return events_by_string(scene, n_strings).get(string, [])


# ---- bends and vibrato ----------------------------------------------------------------------

def max_tension_ratio(events: list, ratio_for_cents) -> float:
    """The largest ratio (``ratio_for_cents`` of the cents) that the bends and vibratos of
    ``events`` reach; 1 without any."""
    r = 1.0
    for e in events:
        if isinstance(e, Bend):
            r = max(r, ratio_for_cents(100.0 * e.semitones))
        elif isinstance(e, Vibrato):
            r = max(r, ratio_for_cents(e.depth_cents))
    return r


def bend_points(e: Bend, on: int, step, ratio: float) -> tuple[list[tuple[int, float]], int]:
    """A bend's breakpoints (step, ratio), linear between them: up to ``ratio`` over its duration
    from step ``on``, held, and back over the same time from its release; and the step it ends
    on.  ``step(t)`` maps seconds to steps; the models differ in what the ratio scales (the
    tension in the finite-difference model, the pitch in the waveguide)."""
    up = max(step(e.duration), 1)
    points = [(on, 1.0), (on + up, ratio)]
    end = on + up
    if e.release is not None:
        rel = max(step(e.release), on + up)
        points += [(rel, ratio), (rel + up, 1.0)]
        end = rel + up
    return points, end


def vibrato_points(e: Vibrato, step, ratio_for_cents) -> tuple[list[tuple[int, float]], int]:
    """A vibrato's breakpoints (step, ``ratio_for_cents`` of its sine's cents at that time),
    ``VIBRATO_POINTS_PER_CYCLE`` per cycle, and the step it ends on."""
    npts = max(int(math.ceil(e.rate_hz * e.duration * VIBRATO_POINTS_PER_CYCLE)), 2)
    points = [(step(e.time + t),
               ratio_for_cents(e.depth_cents * math.sin(2.0 * math.pi * e.rate_hz * t)))
              for t in np.linspace(0.0, e.duration, npts + 1)]
    return points, step(e.time + e.duration)


# ---- a scene cut short ----------------------------------------------------------------------

def truncate(scene: dict[str, Any], seconds: float) -> dict[str, Any]:
    """The first ``seconds`` of a scene in its JSON form (one guitar or tracks), in place: a
    shorter duration and no event from then on.  Releases past the cut stay (the schema allows
    them), so the cut scene renders as the first ``seconds`` of the whole one.  A scene already
    that short, or one whose fields are not what the schema wants (its validation reports them),
    is left as it is."""
    duration = scene.get("duration")
    if not isinstance(duration, int | float) or duration <= seconds:
        return scene
    scene["duration"] = seconds
    tracks = scene.get("tracks")
    holders = [scene, *[t for t in tracks if isinstance(t, dict)]] if isinstance(tracks, list) \
        else [scene]
    for h in holders:
        events = h.get("events")
        if not isinstance(events, list):
            continue
        h["events"] = [e for e in events if not (
            isinstance(e, dict) and isinstance(e.get("time"), int | float)
            and e["time"] >= seconds)]
    return scene
