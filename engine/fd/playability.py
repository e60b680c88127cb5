"""What a scene asks for that may not sound as a player would mean it.

A ``pull_off`` that finds no finger on its fret (it is silent), and a finger pressing with less
than ``intonation.SEAT_MARGIN`` times the force at which its string rests on the fret at all
(``benchmarks/seating.py`` measured that such notes do not hold: the finger pushes the string down
without stopping it, and the note sounds dead or buzzes).  The
messages go back to the user with the audio (``X-Render-Warnings``, ``RenderResult.warnings``).
"""

from __future__ import annotations

import math

from ..options import QUALITY, RenderOptions
from ..performance import FINGER_EVENTS, MAX_FINGERS, events_by_string
from ..presets import Preset
from ..scene import Fret, HammerOn, PullOff, Scene, Slide, Tap
from .controls import frets_pressed
from .intonation import SEAT_MARGIN, seating_force
from .string import StringModel
from .voice import string_model


def finger_warnings(preset: Preset, string: int, events: list, model: StringModel,
                     tension_ratio: float) -> list[tuple[float, int, str]]:
    """``scene_warnings`` for one string's ``events``, on its grid ``model`` at ``tension_ratio``
    times its tuned tension: (time, string, message) of each finger pressing too lightly."""
    out = []
    for e in events:
        if e.type not in FINGER_EVENTS or e.force is None:
            continue
        frets = frets_pressed(e)
        if frets.start < 1:
            continue  # fret 0 lifts the finger
        rests = max(seating_force(model, preset, f, tension_ratio) for f in frets)
        if e.force < SEAT_MARGIN * rests:
            kind = e.type.replace("_", "-")
            where = (f"frets {e.from_fret}-{e.to_fret}" if isinstance(e, Slide)
                     else f"fret {e.fret}")
            out.append((e.time, string, f"string {string}: the {kind} at {e.time:g} s presses "
                                        f"{e.force:g} N; holding the string on {where} takes "
                                        f"about {SEAT_MARGIN * rests:.1f} N (it rests on the "
                                        f"fret from {rests:.2f} N when still): the note may "
                                        "sound dead or buzz"))
    return out


def pull_off_warnings(string: int, events: list) -> list[tuple[float, int, str]]:
    """(time, string, message) of each ``pull_off`` in ``events`` (one string's, in time order)
    that finds no finger on its fret: it lifts nothing and plucks nothing, so it is silent.  The
    fingers are followed as ``engine.fd.controls.string_controls`` places and lifts them (a fret, tap
    or slide replaces the finger on the string, a hammer-on adds one up to ``MAX_FINGERS``, a
    release or a pull-off lifts one)."""
    fingers: list[list[float]] = []  # [fret, on, release] of the fingers not yet lifted
    out = []
    for e in events:
        # a finger lifted at or before this event stays lifted (events come in time order)
        fingers = [f for f in fingers if f[2] > e.time]
        if isinstance(e, Fret | Tap | Slide):
            if not isinstance(e, HammerOn):
                for f in fingers:
                    f[2] = min(f[2], e.time)
            else:
                down = [f for f in fingers if f[1] <= e.time < f[2]]
                for f in down[: max(0, len(down) - MAX_FINGERS + 1)]:
                    f[2] = e.time
            if isinstance(e, Fret) and e.fret == 0:
                continue
            fret = e.to_fret if isinstance(e, Slide) else e.fret
            rel = e.release if e.release is not None else math.inf
            fingers.append([fret, e.time, rel])
        elif isinstance(e, PullOff):
            held = [f for f in fingers if f[0] == e.fret and f[1] <= e.time < f[2]]
            if held:
                held[-1][2] = e.time
            else:
                out.append((e.time, string, f"string {string}: the pull-off at {e.time:g} s finds "
                                            f"no finger on fret {e.fret} (no fret, tap, hammer-on "
                                            "or slide holds it then): it lifts nothing and plays "
                                            "nothing"))
    return out


def scene_warnings(scene: Scene, options: RenderOptions | None = None) -> list[str]:
    """What the scene asks for that may not sound as a player would mean it: a finger pressing
    with less than ``SEAT_MARGIN`` times the force at which its string rests on the fret at all
    (``intonation.seating_force``, on the string's grid as ``prepare`` builds it, at the highest
    tension the scene's bends give the string; a slide: the largest over the frets it crosses).
    Below that force rendered notes were found not to hold (``benchmarks/seating.py``): the finger
    pushes the string down without stopping it, and the note sounds dead or buzzes.  Fingers with
    no force of their own press hard enough (``intonation.press_force``).  In time order.  A
    prepared scene has the same list without building the grids again: ``Guitar.warnings``.
    With ``tracks``, each track's list in turn, each warning prefixed by its track."""
    opts = options or RenderOptions()
    q = opts.quality or QUALITY[scene.quality]
    texts = []
    for t, single in enumerate(scene.track_scenes()):
        preset = single.preset()
        out = []
        by_string = events_by_string(single, preset.n_strings)
        for i in range(1, preset.n_strings + 1):
            events = by_string[i]
            out += pull_off_warnings(i, events)
            if any(e.type in FINGER_EVENTS and e.force is not None for e in events):
                _, model, ratio = string_model(preset, i, events, float(scene.sample_rate), q, opts)
                out += finger_warnings(preset, i, events, model, ratio)
        label = scene.track_label(t)
        texts += [f"{label}: {text}" if label else text for _, _, text in sorted(out)]
    return texts
