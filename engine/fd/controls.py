"""Events -> per-string control arrays the kernel reads (``kernels.Controls``).  The gestures
themselves (where a finger sits, the strum, the hands' contacts, bend and vibrato curves) are
``engine.performance``'s, the same for both models.

Times become step indices at the string's internal rate once, before the loop; the kernel derives
every control value from the global step number, so rendering in blocks of any size gives the same
samples as rendering at once.

How each event acts on the physics
----------------------------------
* ``pluck``: the force pulse f_e(t) of eq. (5); its ``style`` sets the pulse length and direction
  (``PLUCK_STYLES``).  ``strum`` is a sequence of plucks across strings.
* ``fret``/``tap``/``hammer_on``/``slide``: a finger (its own mass, eqs. (9)-(10), with contact
  damping) a fraction ``FINGER_BEHIND`` of the fret spacing behind the fret, pressing with its
  force.  A ``fret``, ``tap`` or ``slide`` lifts the finger already on that string at that moment
  (one hand position per string); a ``hammer_on`` adds a second finger and leaves the first where it
  is.  A ``slide`` moves the finger's position x_FG continuously (the paper's sec. 2.5 allows x_FG to
  vary in time); the string crosses the frets under it.  ``pull_off`` lifts the finger on ``fret``
  and plucks the string at the finger with ``force`` as it leaves.  A lifted finger is pulled up with
  its pressing force and leaves the model once it is ``Coefs.fg_lift`` above the string.  At most
  ``MAX_FINGERS`` fingers are on one string: a hammer-on beyond them lifts the oldest.
* ``harmonic``: a light touch, modelled as a point damper R (d/dt) u(x) with R matched to the
  string's wave impedance 2 sqrt(T rho A) (the value that absorbs most of a wave passing the point),
  with no pressing force: modes with a node at the touch point pass, the others are damped.
* ``mute``: a palm near the bridge, a damper spread over ``PALM_WIDTH_M`` with R = amount * 0.8
  sqrt(T rho A): shorter decay, duller tone.  One palm rests on a string at a time: a later mute
  on the string replaces one still resting (its position and amount take over at its time), and
  likewise a later harmonic touch replaces an earlier one.  So the contacts acting at once, each a
  column of the kernel's small solve, stay few however many events a scene sends.
* ``damp``: the player stops the string.  Any fretting finger lifts (relaxes: it stops pressing)
  and the hand's fingertips rest on the string from where that finger was (or from over fret
  ``DAMP_OPEN_FRET`` on an open string) towards the bridge: ``DAMP_FINGERS`` point dampers
  ``DAMP_SPACING_M`` apart, each R = ``DAMP_DAMPING`` sqrt(T rho A), losses in the balance's Q.
  They stay until the string's next event (of any type); a second damp before then replaces the
  first.  docs/engine.md gives the decay times.
* ``bend``/``vibrato``: the tension T(t) = T0 * ratio(t), piecewise linear between breakpoints; the
  ratio for a pitch change is solved from the scheme's dispersion relation.  The grid is built for
  the highest tension the scene reaches (``max_tension_ratio``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..performance import (
    DAMP_DAMPING,
    DAMP_FINGERS,
    DAMP_OPEN_FRET,
    DAMP_SPACING_M,
    HARMONIC_DAMPING,
    MAX_FINGERS,
    PALM_DAMPING,
    PALM_WIDTH_M,
    PLUCK_STYLES,
    bend_points,
    finger_x_m,
    vibrato_points,
)
from ..presets import Preset
from ..scene import (
    Bend,
    Damp,
    Fret,
    HammerOn,
    Harmonic,
    Mute,
    Pluck,
    PullOff,
    Slide,
    Tap,
    Vibrato,
)
from .kernels import Controls, interp

TAP_GAP_S = 1e-3  # a tap starts this long (at its velocity) above the string
# a finger has landed this long after it is put down: from then on it has the damping calibrated
# for its fret (``engine.fd.intonation.finger_damping``), while it lands the preset's, which sets how
# a tap strikes the string and how deep it drives it (``test_stress.py``'s hard taps)
FINGER_SETTLE_S = 10e-3
NEVER = np.iinfo(np.int64).max // 4


@dataclass(frozen=True)
class FingerMotion:
    """How fast one finger of the scene can move the string (``string.fret_margin`` bounds it)."""

    v0: float  # speed towards the fretboard when it is put down (taps, hammer-ons), m/s
    force: float  # pressing force (and lifting force after its release), N
    gap: float  # height above the string when it is put down, m
    glide: float  # speed along the string (slides), m/s


@dataclass
class StringControls:
    arrays: Controls
    last_step: int  # the last step at which any control changes (for the decay skip)
    max_pluck_force: float  # the largest sum of |force| of the pluck pulses acting at one step
    fingers: tuple[FingerMotion, ...] = ()

    @property
    def silent(self) -> bool:
        return self.arrays.pl_start.size == 0 and self.arrays.fs_on.size == 0


def stopped_frets(events: list) -> tuple[int, ...]:
    """The frets that the fingers of ``events`` stop, sorted: a slide stops at its two ends (on
    its way the finger is between the frets' stopping positions, where no calibration applies)."""
    frets: set[int] = set()
    for e in events:
        if isinstance(e, Slide):
            frets.update((e.from_fret, e.to_fret))
        elif isinstance(e, Fret | Tap):
            frets.add(e.fret)
    return tuple(sorted(frets - {0}))


def frets_pressed(e) -> range:
    """The frets a finger event presses on: its fret, or every fret a slide crosses."""
    if isinstance(e, Slide):
        return range(min(e.from_fret, e.to_fret), max(e.from_fret, e.to_fret) + 1)
    return range(e.fret, e.fret + 1)


def string_controls(events: list, preset: Preset, string: int, h: float, n: int, rate: float,
                    impedance: float, ratio_for_cents,
                    fret_shifts: dict[int, float] | None = None,
                    press_force=None,
                    finger_damping: dict[int, float] | None = None) -> StringControls:
    """Compile ``events`` (already on ``string``, sorted) for a grid of spacing h at ``rate`` Hz.

    ``impedance`` is sqrt(T rho A); ``ratio_for_cents(c)`` the tension ratio that raises the pitch
    by c cents.  ``fret_shifts`` (fret -> metres, ``engine.fd.intonation``) moves a finger stopping
    a calibrated fret along with that fret's interpolant.  ``press_force(fret)`` is the force of a
    finger whose event gives none (``engine.fd.intonation.press_force``; default: the preset's); a
    slide presses with the largest over the frets it crosses.  ``finger_damping`` (fret -> N s/m,
    ``engine.fd.intonation``) is the contact damping of a finger stopping a calibrated fret (a slide:
    the fret it ends on) once it has landed (``FINGER_SETTLE_S`` after it is put down); while it
    lands, and elsewhere, the preset's.
    """
    length_m = preset.string_length_m(string)
    spec = preset.strings[string - 1]
    shifts = fret_shifts or {}
    damping = finger_damping or {}

    def default_force(frets: range) -> float:
        if press_force is None:
            return preset.finger.press_force_n
        return max(press_force(q) for q in frets)

    placed: dict[int, float] = {}

    def finger_at(fret: int) -> float:
        if fret not in placed:
            placed[fret] = finger_x_m(preset, fret, spec) + shifts.get(fret, 0.0)
        return placed[fret]

    def step(t: float) -> int:
        # a time past the render's end is as good as never (the schema bounds times and releases;
        # this keeps every step count inside the kernels' int64 arithmetic whatever the rate)
        return min(int(round(t * rate)), NEVER)

    plucks: list[tuple] = []
    slots: list[dict] = []
    # The slots and dampers that the current event or a later one may still change: those
    # released after it.  One released at or before it is final (events come in time order, and
    # every change below applies from the event's step on), so each event scans only these and
    # a song's controls compile in time linear in its events.
    held_slots: list[dict] = []
    resting: dict[str, list[list]] = {"palm": [], "touch": [], "damp": []}
    palms: list[list] = []  # [on, off, R, points] of each mute
    touches: list[list] = []  # ... and of each harmonic touch
    bends: list[tuple[int, float]] = []
    last = 0

    def add_pluck(t, x_m, force, duration):
        nonlocal last
        p, w0, w1 = interp(x_m, h, n)
        ln = max(1, step(duration))
        plucks.append((step(t), ln, force, p, w0, w1))
        last = max(last, step(t) + ln)

    def lift(at: int, only=None):
        for s in held_slots:
            if s["rel"] > at and (only is None or s is only):
                s["rel"] = at

    def end_touch(kind: str, at: int) -> None:
        # one palm (one touching finger) per string: a later one replaces an earlier one still
        # resting, from its start on (stacked contacts would each add a column to the kernel's
        # small solve, whose cost grows with the cube of their number)
        for d in resting[kind]:
            if d[1] > at:
                d[1] = at

    damps: list[list] = []  # the relaxed hand's pads (``damp``), until the string's next event
    before = 0
    for j, e in enumerate(events):
        on = step(e.time)
        if on < before:  # out of time order: every slot and damper may change again
            held_slots = list(slots)
            resting = {"palm": list(palms), "touch": list(touches), "damp": list(damps)}
        before = on
        if held_slots:
            held_slots = [s for s in held_slots if s["rel"] > on]
        for kind, ds in resting.items():
            if ds:
                resting[kind] = [d for d in ds if d[1] > on]
        last = max(last, on)
        if isinstance(e, Pluck):
            dur, sign = PLUCK_STYLES[e.style]
            add_pluck(e.time, e.position * length_m, sign * e.force, e.duration or dur)
        elif isinstance(e, Fret | Tap | Slide):  # HammerOn is a Tap that keeps other fingers
            if not isinstance(e, HammerOn):
                lift(on)
            else:  # a hand has MAX_FINGERS fingers: a hammer-on beyond them lifts the oldest
                down = [s for s in held_slots if s["on"] <= on < s["rel"]]
                for s in down[: max(0, len(down) - MAX_FINGERS + 1)]:
                    s["rel"] = on
            if isinstance(e, Fret) and e.fret == 0:
                continue
            rel = step(e.release) if e.release is not None else NEVER
            if e.release is not None:
                last = max(last, rel)
            v0 = e.velocity if isinstance(e, Tap) else 0.0
            if isinstance(e, Slide):
                x0, x1 = finger_at(e.from_fret), finger_at(e.to_fret)
                ms, me = on, on + max(step(e.duration), 1)
                last = max(last, me)
            else:
                x0 = x1 = finger_at(e.fret)
                ms = me = 0
            fret = e.to_fret if isinstance(e, Slide) else e.fret
            force = e.force if e.force is not None else default_force(frets_pressed(e))
            r = damping.get(fret, preset.finger.damping_n_s_m)
            settle = on + step(FINGER_SETTLE_S) if r != preset.finger.damping_n_s_m else on
            slots.append(dict(on=on, rel=rel, x0=x0, x1=x1, ms=ms, me=me, force=force, v0=v0,
                              gap=v0 * TAP_GAP_S, fret=fret, r=r, rs=settle))
            held_slots.append(slots[-1])
        elif isinstance(e, PullOff):
            held = [s for s in held_slots if s["fret"] == e.fret and s["on"] <= on < s["rel"]]
            if held:
                lift(on, held[-1])
                add_pluck(e.time, held[-1]["x1"], e.force, PLUCK_STYLES["finger"][0])
        elif isinstance(e, Harmonic):
            x = preset.fret_x_m(e.fret, spec) if e.fret is not None else e.position * length_m
            off = step(e.release) if e.release is not None else NEVER
            last = max(last, on if off == NEVER else off)
            end_touch("touch", on)
            touches.append([on, off, HARMONIC_DAMPING * impedance, [(x, 1.0)]])
            resting["touch"].append(touches[-1])
        elif isinstance(e, Mute):
            off = step(e.release) if e.release is not None else NEVER
            last = max(last, on if off == NEVER else off)
            centre = e.position * length_m
            xs = centre + np.linspace(-0.5, 0.5, 5) * PALM_WIDTH_M
            end_touch("palm", on)
            palms.append([on, off, e.amount * PALM_DAMPING * impedance,
                          [(float(xv), 0.2) for xv in xs]])
            resting["palm"].append(palms[-1])
        elif isinstance(e, Damp):
            held = [s for s in held_slots if s["on"] <= on < s["rel"]]
            x = held[-1]["x1"] if held else finger_at(DAMP_OPEN_FRET)
            lift(on)
            off = step(events[j + 1].time) if j + 1 < len(events) else NEVER
            last = max(last, on if off == NEVER else off)
            end_touch("damp", on)  # a second damp before the next event replaces the first
            for k in range(DAMP_FINGERS):  # one pad per finger, towards the bridge
                xk = min(x + k * DAMP_SPACING_M, 0.9 * length_m)
                damps.append([on, off, DAMP_DAMPING * impedance, [(xk, 1.0)]])
                resting["damp"].append(damps[-1])
        elif isinstance(e, Bend):
            points, end = bend_points(e, on, step, ratio_for_cents(100.0 * e.semitones))
            bends += points
            last = max(last, end)
        elif isinstance(e, Vibrato):
            points, end = vibrato_points(e, step, ratio_for_cents)
            bends += points
            last = max(last, end)
    fingers = tuple(FingerMotion(s["v0"], s["force"], s["gap"],
                                 abs(s["x1"] - s["x0"]) * rate / max(s["me"] - s["ms"], 1))
                    for s in slots)
    # a replaced-at-once one never acts
    dampers = [d for d in palms + touches + damps if d[1] > d[0]]
    return StringControls(_arrays(plucks, slots, dampers, bends, h, n), last,
                          _peak_total_force(plucks), fingers)


def _peak_total_force(plucks) -> float:
    """The largest sum of |peak force| over pluck pulses that overlap in time (steps start ..
    start + len): stacked plucks (a strum and a pluck, pull-offs) push the string together."""
    edges = sorted([(p[0], 1, abs(p[2])) for p in plucks] + [(p[0] + p[1] + 1, 0, abs(p[2]))
                                                            for p in plucks])
    total = peak = 0.0
    for _step, starts, f in edges:  # at equal steps the ends (0) come before the starts (1)
        total += f if starts else -f
        peak = max(peak, total)
    return peak


def _arrays(plucks, slots, dampers, bends, h, n) -> Controls:
    i64 = np.int64
    pl = np.array(plucks, dtype=float).reshape(-1, 6)
    dp_ptr = [0]
    dp_idx: list[int] = []
    dp_w: list[float] = []
    for _on, _off, _r, points in dampers:
        spread: dict[int, float] = {}
        for x, weight in points:
            p, w0, w1 = interp(x, h, n)
            spread[p] = spread.get(p, 0.0) + weight * w0
            spread[p + 1] = spread.get(p + 1, 0.0) + weight * w1
        for p, w in sorted(spread.items()):
            if w != 0.0:
                dp_idx.append(p)
                dp_w.append(w)
        dp_ptr.append(len(dp_idx))
    bends = sorted(bends, key=lambda b: b[0])
    return Controls(
        pl_start=pl[:, 0].astype(i64),
        pl_len=pl[:, 1].astype(i64),
        pl_amp=pl[:, 2].copy(),
        pl_p=pl[:, 3].astype(i64),
        pl_w0=pl[:, 4].copy(),
        pl_w1=pl[:, 5].copy(),
        fs_on=np.array([s["on"] for s in slots], i64),
        fs_rel=np.array([s["rel"] for s in slots], i64),
        fs_x0=np.array([s["x0"] for s in slots], float),
        fs_x1=np.array([s["x1"] for s in slots], float),
        fs_ms=np.array([s["ms"] for s in slots], i64),
        fs_me=np.array([s["me"] for s in slots], i64),
        fs_force=np.array([s["force"] for s in slots], float),
        fs_v0=np.array([s["v0"] for s in slots], float),
        fs_gap=np.array([s["gap"] for s in slots], float),
        fs_r=np.array([s["r"] for s in slots], float),
        fs_rs=np.array([s["rs"] for s in slots], i64),
        dp_on=np.array([d[0] for d in dampers], i64),
        dp_off=np.array([d[1] for d in dampers], i64),
        dp_r=np.array([d[2] for d in dampers], float),
        dp_ptr=np.array(dp_ptr, i64),
        dp_idx=np.array(dp_idx, i64),
        dp_w=np.array(dp_w, float),
        tb_step=np.array([b[0] for b in bends], i64),
        tb_ratio=np.array([b[1] for b in bends], float),
    )
