"""Scene events -> one waveguide string's timeline: where it is stopped, its pitch ratio, and the
junctions that act on it.

Every event type of the scene maps to the model:

* ``pluck`` (every ``style``) and ``strum`` (split into plucks as the finite-difference model
  does, ``engine.performance.expand``): a plucking junction (``pluck``) carrying the pulse F0(t).
* ``fret``, ``tap``, ``hammer_on``, ``slide``: fingers.  A finger that presses at least the
  string's seating force (``engine.statics.PressedString``, the pressed string's statics; a
  finger with no force of its own presses hard enough) stops the string on its fret: the
  termination moves to the crown (``fingering``); the stopping fret is the seated finger's nearest
  the bridge.  ``fret``/``tap``/``slide`` lift the finger already on the string, ``hammer_on``
  keeps it (two fingers), ``fret: 0`` and ``release`` lift.  A lighter finger touches without
  stopping: the light fingering junction (the finger pad's damping, ``DEAD_DAMPING``, spread
  over ``FINGER_PAD_M``; a dead note).  ``tap`` and ``hammer_on`` strike: the string is carried
  onto the crown at the finger's ``velocity`` (``voice``).
  A ``slide`` moves the finger from ``from_fret`` to ``to_fret`` at constant speed; the string
  is stopped by the first crown ahead of the finger, so the pitch steps through the frets it
  crosses (a glissando, as on the finite-difference model's string).
* ``pull_off``: the finger on ``fret`` lifts, with a pluck of ``force`` at the finger (style
  ``finger``); the lower finger, or the nut, stops the string.
* ``harmonic``: the harmonics junction, a light touch: the plucking junction with no mass or
  spring and a damper R = ``HARMONIC_DAMPING`` sqrt(T mu) (the finite-difference model's value),
  split between the two grid points around the touch, until ``release``.
* ``mute``: the palm: dampers R = amount ``PALM_DAMPING`` sqrt(T mu) in total over
  ``PALM_WIDTH_M`` around ``position`` (the finite-difference model's values), until ``release``.
* ``bend``, ``vibrato``: the pitch ratio, piecewise linear in time (a bend rises to 2^(s/12)
  over ``duration``, holds until ``release``, returns over ``duration``; a vibrato is sampled 32
  times a cycle), applied to the loop's period (``string``).
* ``damp``: the finite-difference model's dampers (``engine.performance.DAMP_*``: any finger lifts,
  and the relaxed hand's fingertips rest on the string from where the fretting finger was
  towards the bridge) as harmonics junctions, until the string's next event.

Any other event type raises ValueError naming it.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass, field

import numpy as np

from ..performance import (
    DAMP_DAMPING,
    DAMP_FINGERS,
    DAMP_OPEN_FRET,
    DAMP_SPACING_M,
    HARMONIC_DAMPING,
    PALM_DAMPING,
    PALM_WIDTH_M,
    PLUCK_STYLES,
    bend_points,
    events_on,
    finger_x_m,
    vibrato_points,
)
from ..presets import Preset, StringSpec

# a finger resting on the string without stopping it: its pad's damping, spread over the pad.  The
# finger's mass sits behind the soft pad and barely moves with the string at audio frequencies;
# a rigid mass (or a damper far above the string's impedance) would reflect the waves and leave a
# stopped, ringing note instead of a dead one.  R in total, x sqrt(T mu): near the value that
# absorbs most of a passing wave (R = 2 sqrt(T mu) at one point)
DEAD_DAMPING = 3.0
FINGER_PAD_M = 0.015
NEVER = np.iinfo(np.int64).max // 4


@dataclass
class Finger:
    fret: int
    on: int
    rel: int
    seated: bool
    force: float
    strike: float  # a tap's or hammer-on's speed towards the fretboard (m/s); 0: pressed
    slide: tuple | None = None  # (start step, end step, x0, x1) of the finger's glide
    slot: int | None = None  # the light fingering junction of a finger that does not stop


@dataclass
class Slot:
    """A junction of ``pluck``: on/off steps, pulse length (0: steady), the point x (m), the
    contact (peak values) and the force."""

    on: int
    off: int
    length: int
    x_m: float
    mass: float
    stiffness: float
    damping: float
    force: float
    width_m: float
    window: str  # "bell", "triangle" or "split" (two points around x)


@dataclass
class Timeline:
    fingers: list[Finger] = field(default_factory=list)
    slots: list[Slot] = field(default_factory=list)
    ratio_steps: list[int] = field(default_factory=list)
    ratios: list[float] = field(default_factory=list)
    last_step: int = 0

    def stops(self, preset: Preset, spec: StringSpec
              ) -> list[tuple[int, int | None, float, bool]]:
        """(step, stopping fret or None, strike speed: m/s, 0 for none; held) at every change of
        the stopping fret on string ``spec`` (its frets measured from its compensated nut), or of
        whether a finger rests on it: ``held`` where the finger stopping it is not on its way
        (a fretted, tapped or hammered note; a slide before it moves and at its goal), not where
        a sliding finger passes the crowns (``fingering.finger_reflection``).  Each depends on
        its finger's own event only, not on the events after it, so a live session decides it
        as a render does."""
        points = {0}
        crowns: list[float] | None = None  # the frets' x, asked for only where a finger slides
        for f in self.fingers:
            if not f.seated:
                continue
            points.update((f.on, f.rel))
            if f.slide is not None:
                ms, me, x0, x1 = f.slide
                crowns = crowns or _crowns(preset, spec)
                for xq in crowns:  # the step the finger passes each crown
                    if min(x0, x1) < xq < max(x0, x1) and me > ms:
                        at = ms + (xq - x0) / (x1 - x0) * (me - ms)
                        points.update((int(math.floor(at)), int(math.floor(at)) + 1))
                points.update((ms, me))
        out: list[tuple[int, int | None, float, bool]] = []
        # the seated fingers down at each step, in their order (a song's string has hundreds of
        # fingers, a step one or two): taken on in the order they come, dropped once lifted
        coming = sorted((f.on, i) for i, f in enumerate(self.fingers) if f.seated)
        down: list[int] = []
        c = 0
        for step in sorted(p for p in points if p < NEVER):
            while c < len(coming) and coming[c][0] <= step:
                bisect.insort(down, coming[c][1])
                c += 1
            down = [i for i in down if step < self.fingers[i].rel]
            best, strike, held = None, 0.0, False
            for i in down:
                f = self.fingers[i]
                q = _stopping_fret(crowns, f, step)
                resting = f.slide is None or not f.slide[0] <= step < f.slide[1]
                if q is not None and (best is None or q > best):
                    best, strike, held = q, f.strike if f.on == step else 0.0, resting
                elif q is not None and q == best:
                    held = held or resting
            if not out or (out[-1][1], out[-1][3]) != (best, held):
                out.append((step, best, strike, held))
        return out


def _crowns(preset: Preset, spec: StringSpec) -> list[float]:
    """x of frets 1..frets on string ``spec`` (``Preset.fret_x_m``, each as it gives it alone):
    asked for once a compilation, not once a fret a step (a string's compilation is on a live
    session's audio thread, ``engine.live``)."""
    return [float(preset.fret_x_m(q, spec)) for q in range(1, preset.frets + 1)]


def _stopping_fret(crowns: list[float] | None, f: Finger, step: int) -> int | None:
    """The fret finger ``f`` stops at ``step``: its own, or while it slides the first crown past
    it, the last fret at most (``crowns``: ``_crowns``, known whenever a finger slides)."""
    if f.slide is None:
        return f.fret
    assert crowns is not None
    ms, me, x0, x1 = f.slide
    a = 0.0 if step <= ms else 1.0 if step >= me else (step - ms) / (me - ms)
    x = x0 + a * (x1 - x0)
    for q, xq in enumerate(crowns, 1):
        if xq > x:
            return q
    return len(crowns)


def timeline(scene, preset: Preset, string: int, rate: float, impedance: float,
             seated, events: list | None = None) -> Timeline:
    """The events of ``scene`` on ``string`` compiled at ``rate`` Hz (or ``events``, that
    string's own, strums already split: a live session's, ``engine.live``).  ``impedance`` is
    sqrt(T mu); ``seated(fret, force)`` says whether a finger pressing ``force`` N (None: the
    default press) rests on ``fret``."""
    from .pluck import STYLES

    spec = preset.strings[string - 1]  # positions from its nut, less its nut compensation
    length = preset.string_length_m(string)
    if events is None:
        events = events_on(scene, preset.n_strings, string)
    events = sorted(events, key=lambda e: e.time)
    times = [e.time for e in events]
    tl = Timeline()

    def step(t: float) -> int:
        return int(round(t * rate))

    placed: dict[int, float] = {}

    def finger_at(fret: int) -> float:
        """``finger_x_m`` of ``fret`` on this string, computed once a fret (a song's string is
        fretted and damped thousands of times on a few frets)."""
        if fret not in placed:
            placed[fret] = finger_x_m(preset, fret, spec)
        return placed[fret]

    # the fingers not lifted before the current event: one lifted at or before it stays lifted
    # (events come in time order), so each event scans only these, and a song's timeline is
    # compiled in time linear in its events
    down: list = []

    def lift(at: int, only=None):
        for f in down:
            if f.rel > at and f.on <= at and (only is None or f is only):
                f.rel = at

    def add_pluck(on, x_m, force, style, duration=None):
        dur, sign = PLUCK_STYLES[style]
        c = STYLES[style]
        n = max(1, step(duration or dur))
        tl.slots.append(Slot(on, on + n + 1, n, x_m, c.mass_kg, c.stiffness_n_m, c.damping_n_s_m,
                             sign * force, c.width_m, c.window))
        tl.last_step = max(tl.last_step, on + n + 1)

    bends: list[tuple[int, float]] = []
    before = 0
    for j, e in enumerate(events):
        on = step(e.time)
        if on < before:  # out of time order (a caller's list): every finger may change again
            down = list(tl.fingers)
        before = on
        down = [f for f in down if f.rel > on]
        tl.last_step = max(tl.last_step, on)
        kind = e.type
        if kind == "pluck":
            add_pluck(on, e.position * length, e.force, e.style, e.duration)
        elif kind in ("fret", "tap", "hammer_on", "slide"):
            if kind != "hammer_on":
                lift(on)
            if kind == "fret" and e.fret == 0:
                continue
            rel = step(e.release) if e.release is not None else NEVER
            if rel < NEVER:
                tl.last_step = max(tl.last_step, rel)
            fret = e.to_fret if kind == "slide" else e.fret
            frets = (range(min(e.from_fret, e.to_fret), max(e.from_fret, e.to_fret) + 1)
                     if kind == "slide" else (fret,))
            ok = all(seated(q, e.force) for q in frets)
            slide = None
            if kind == "slide":
                me = on + max(step(e.duration), 1)
                slide = (on, me, finger_at(e.from_fret), finger_at(e.to_fret))
                tl.last_step = max(tl.last_step, me)
            start = e.from_fret if kind == "slide" else fret
            tl.fingers.append(Finger(start, on, rel, ok, e.force if e.force is not None else 0.0,
                                     e.velocity if kind in ("tap", "hammer_on") else 0.0, slide))
            down.append(tl.fingers[-1])
            if kind == "slide":
                tl.fingers[-1].fret = fret
            if not ok:  # a finger touching without stopping: the light fingering junction
                x = finger_at(fret)
                tl.fingers[-1].slot = len(tl.slots)
                tl.slots.append(Slot(on, rel, 0, x, 0.0, 0.0, DEAD_DAMPING * impedance, 0.0,
                                     FINGER_PAD_M, "bell"))
        elif kind == "pull_off":
            held = [f for f in down if f.fret == e.fret and f.on <= on < f.rel]
            if held:
                lift(on, held[-1])
                add_pluck(on, finger_at(e.fret), e.force, "finger")
        elif kind == "harmonic":
            x = float(preset.fret_x_m(e.fret, spec)) if e.fret is not None else e.position * length
            off = step(e.release) if e.release is not None else NEVER
            tl.last_step = max(tl.last_step, on if off == NEVER else off)
            tl.slots.append(Slot(on, off, 0, x, 0.0, 0.0, HARMONIC_DAMPING * impedance, 0.0, 0.0,
                                 "split"))
        elif kind == "mute":
            off = step(e.release) if e.release is not None else NEVER
            tl.last_step = max(tl.last_step, on if off == NEVER else off)
            for xv in e.position * length + np.linspace(-0.5, 0.5, 5) * PALM_WIDTH_M:
                tl.slots.append(Slot(on, off, 0, float(xv), 0.0, 0.0,
                                     0.2 * e.amount * PALM_DAMPING * impedance, 0.0, 0.0, "split"))
        elif kind == "bend":
            points, end = bend_points(e, on, step, 2.0 ** (e.semitones / 12.0))
            bends += points
            tl.last_step = max(tl.last_step, end)
        elif kind == "vibrato":
            points, end = vibrato_points(e, step, lambda cents: 2.0 ** (cents / 1200.0))
            bends += points
            tl.last_step = max(tl.last_step, end)
        elif kind == "damp":  # until the string's first later event
            later = bisect.bisect_right(times, e.time, j + 1)
            off = step(times[later]) if later < len(times) else NEVER
            _damp(tl, on, off, down, finger_at, length, impedance)
        else:
            raise ValueError(f"events: type {kind!r} has no waveguide mapping")
    for f in tl.fingers:  # a light finger's junction ends when the finger lifts
        if f.slot is not None:
            tl.slots[f.slot].off = min(tl.slots[f.slot].off, f.rel)
    bends.sort(key=lambda b: b[0])
    if not bends or bends[0][0] > 0:
        bends.insert(0, (0, 1.0))
    steps, ratios = [], []
    for s, r in bends:  # a later breakpoint at the same step wins
        if steps and steps[-1] == s:
            ratios[-1] = r
        else:
            steps.append(s)
            ratios.append(r)
    tl.ratio_steps, tl.ratios = steps, ratios
    return tl


def _damp(tl: Timeline, on: int, off: int, down: list, finger_at, length: float,
          impedance: float) -> None:
    """A ``damp`` from step ``on`` to ``off`` (the string's next event, NEVER if none), as the
    finite-difference model has it (``engine.performance.DAMP_*``): every finger on the string
    lifts (relaxes), and the relaxed hand's fingertips rest on it from where the fretting finger
    was (fret ``DAMP_OPEN_FRET``'s place on an open string) towards the bridge,
    ``DAMP_FINGERS`` dampers of R = ``DAMP_DAMPING`` sqrt(T mu) ``DAMP_SPACING_M`` apart.
    ``down``: the fingers not lifted before it; ``finger_at(fret)``: ``finger_x_m`` of the
    string's ``fret``."""
    held = [f for f in down if f.on <= on < f.rel]
    fret = held[-1].fret if held else DAMP_OPEN_FRET
    x = finger_at(fret)
    for f in held:
        f.rel = on
    for k in range(DAMP_FINGERS):
        xk = min(x + k * DAMP_SPACING_M, 0.9 * length)
        tl.slots.append(Slot(on, off, 0, xk, 0.0, 0.0, DAMP_DAMPING * impedance, 0.0, 0.0,
                             "split"))
    tl.last_step = max(tl.last_step, on if off == NEVER else off)
