"""The fingering junction: a finger stopping the string at a fret (E&E sec. IV-B, Fig. 7).

E&E terminate the string at the pressing point n_f with a fingering junction (the plucking
junction of eq. (21) without the force) backed, towards the nut, by a damped reflector of gain
g_f <= 1 with a sign inversion; the terminated junction's transfer function is

    L(z) = U_out+ / U_in- = (1 - A(z) - 2 g_f z^-2) / (2 A(z) + g_f z^-2 (1 - A(z)))      (40)

and in the large finger-mass limit (A -> infinity, the finger pressed onto the neck)

    L(z) = -1 / (2 - g_f z^-2).                                                          (41)

On a fretless neck the finger itself stops the string and (41) is its imperfect clamp.  On a
fretted neck the string is stopped by the fret's crown, a rigid knife edge, with the finger a few
millimetres behind it: less than one grid step at 44.1 kHz on the treble strings.  (41) would
make the crown a low-pass reflector losing 22 % of the amplitude per period at 2 kHz, which no
fretted steel string does.  This model therefore keeps Fig. 7's structure (the speaking string
ends at a reflecting termination with a gain g_f and a sign inversion, and the string beyond it
towards the nut is cut off) with the reflection at the crown: the termination of ``string`` moved
to the fret, reflection -g_f.  The crown reflects fully (``FRET_REFLECTION``); what g_f loses is
the finger's: its flesh (the finite-difference model's contact damper, ``FingerSpec.damping_n_s_m``,
on its mass and contact spring a few millimetres behind the crown) takes energy from the held
note through the string's bending over the crown.  That coupling is the finite-difference
model's physics, which the waveguide's point termination does not have, so g_f is fitted to it:
the finite-difference model's own linear analysis of the held note on its converged grid
(``engine.fd.statics``, handed to the waveguide as an ``engine.statics.PressedString`` by
``engine.models``) gives the held mode's decay by the finger, D dB/s (``finger_decay_db_s``), and

    g_f = 10^(D / (20 f1)),                                                      (``finger_reflection``)

the amplitude the mode loses per period, a frequency-independent loss of the loop: every partial
of the stopped loop decays D dB/s faster than the loss filter alone makes it (the finger's own
decay is fitted at the fundamental only).  g_f <= 1: passive.  It applies where a finger rests
on the fret (a fretted, tapped or hammered note, a slide before it moves and from its goal on);
the crowns a sliding finger passes stop the string by the crown alone (the finger's effect over
a few milliseconds is below a tenth of a dB, and each fret's analysis costs an eigenvalue
problem).  Whether a finger rests is its own event's to say (``controls.Timeline.stops``), not
the later events', so a live session damps a note as a render does from the step the finger
lands.  Each fret's analysis is kept per process and on disk per machine as the
finite-difference model's fret calibrations are (``engine.calibration_store``); a live session's
guitar (``RenderOptions.live_grid``) computes every fret's when it is prepared, so that no note
held later waits for it.
``benchmarks/waveguide.py`` prints the fretted notes' decay against the finite-difference
reference.  The light fingering junction of (40)
without its reflector (finger mass, stiffness and damping at the finger, no stopping) is kept for
what it models well, a finger that touches without stopping: a dead note (a ``fret`` pressing
less than the string's seating force, ``PressedString.seating_force_n``), the harmonic touch and
the palm (``pluck``, ``controls``).

Pitch of a stopped string.  The termination's delay is tuned so the stopped loop sounds f_q
(``string``).  Two intonation models:

* ``ideal`` (default): a perfectly compensated instrument: the finger at x metres from the
  string's nut (nearer the frets than the scale's by its nut compensation n, as every position
  here: ``Preset.fret_x_m`` with the string's spec) sounds f0 * S / (S - n - x), S the scale
  length; at the frets that is the equal-tempered f0 * 2^(q / 12).  This is the waveguide
  synthesiser's convention (E&E: the fractional delays "also serve for fine tuning the model to
  correct pitch").
* ``physical``: the stopped stiff string on the preset's geometry: the speaking length L - x_q
  (L = S + setback - n and x_q from the string's nut, so L - x_q = S 2^(-q/12) + setback), the
  tension raised by pressing (the string bent from the nut down to the finger and the crown:
  E A dL / L, the finger's press force against the tension setting its depth), and the bending
  stiffness carrying over the crown, which shortens the speaking length by half the clamped-end
  correction, ell / 2 with ell = sqrt(E I / T)
  (``stopped_frequency``).  ``benchmarks/waveguide.py --intonation`` prints where this lands
  against 12-TET at frets 1-12 of the steel preset: within a cent (its docstring has the
  figure), as the presets' saddle setbacks and nut compensations, fitted to the
  finite-difference physics, tune this model too.

Passivity: the termination's reflection has |.| = g_f <= 1 times the passive loop filters of
``string``; cutting the string at the crown discards the waves on the nut side (energy lost, never
gained).  When the finger lifts, the cut-off part is put back at rest on the string's new rest line
and the string is released from its pressed shape (the displacement is continuous, its velocity
unchanged): the energy that appears is the potential energy the finger's work stored in the
pressed shape.
"""

from __future__ import annotations

import math
from functools import lru_cache

from .. import calibration_store
from ..performance import finger_x_m
from ..presets import Preset
from ..statics import PressedString
from .string import Physical

FRET_REFLECTION = 1.0  # the crown's own reflection
INTONATION = ("ideal", "physical")
# the code ``finger_decay_db_s`` adds to the fret calibrations' (``calibration_store._SOURCES``),
# with its analysis' (``PressedString.sources``)
SOURCES = ("waveguide/fingering.py",)


@lru_cache(maxsize=4096)
def finger_decay_db_s(statics: PressedString, preset: Preset, string: int, rate: float,
                      fret: int) -> float:
    """dB/s (<= 0) of the held note at ``fret`` by the finger's contact damping: the
    finite-difference model's held-note analysis on its converged grid
    (``statics.held_note_decay_db_s``); 0 where it finds no mode near the note.  Cached per
    process, and on disk per machine (``engine.calibration_store``: the value read back is the one
    computed, to the bit)."""
    rate = float(rate)

    def compute() -> tuple[float]:
        d = statics.held_note_decay_db_s(preset, string, rate, fret)
        return (min(d, 0.0) if math.isfinite(d) else 0.0,)

    return calibration_store.recall("finger_decay_db_s", (preset, string, rate, fret), compute,
                                    sources=SOURCES + statics.sources)[0]


def finger_decays(statics: PressedString, preset: Preset, string: int, rate: float,
                  frets) -> dict[int, float]:
    """``finger_decay_db_s`` of each of ``frets`` (a live session's: every fret, computed when
    its guitar is prepared rather than when a note is first held)."""
    return {q: finger_decay_db_s(statics, preset, string, rate, q) for q in frets}


def finger_reflection(decay_db_s: float, f1: float) -> float:
    """g_f: the amplitude a loop of fundamental f1 Hz keeps per period when it decays
    ``decay_db_s`` (<= 0) dB/s."""
    return 10.0 ** (min(decay_db_s, 0.0) / (20.0 * f1))


def stopped_frequency(preset: Preset, phys: Physical, string: int, x_m: float, fret: int | None,
                      intonation: str, press_force: float) -> float:
    """Fundamental (Hz) of string ``string`` stopped x_m metres from its nut, which its nut
    compensation n puts that much nearer the frets (``Preset.fret_x_m`` with its spec; ``fret``
    when x_m is on one; None for a point between frets during a slide, where the physical model
    interpolates)."""
    if x_m <= 0.0:
        return phys.f0
    spec = preset.strings[string - 1]
    scale = preset.scale_length_m
    f_ideal = phys.f0 * scale / (scale - spec.nut_compensation_m - x_m)  # x_m + n: from the scale's nut
    if intonation == "ideal":
        return f_ideal
    if fret is None:
        return f_ideal  # a finger between frets (a slide on its way) stops on no crown
    length = phys.length_m
    c = float(preset.clearance_m(x_m))
    xf = finger_x_m(preset, fret, spec)
    a = max(x_m - xf, 1e-4)
    t0 = phys.tension_n
    depth = (press_force / t0 + c / a) / (1.0 / xf + 1.0 / a)
    stretch = depth**2 / (2 * xf) + (depth - c) ** 2 / (2 * a) + c * c / (2 * (length - x_m))
    tension = t0 + phys.ea * stretch / length
    speaking = length - x_m
    ell = math.sqrt(phys.ei / tension)
    b = math.pi**2 * phys.ei / (tension * speaking**2)
    return math.sqrt(tension / phys.mu) / (2.0 * (speaking - 0.5 * ell)) * math.sqrt(1.0 + b)


def rest_height(preset: Preset, length_m: float, stop_x: float | None, x_m: float) -> float:
    """Height (m, negative: towards the fretboard) of the string's rest line at x_m when it is
    stopped on the fret crown at stop_x (None: the open string, a straight line): straight from the
    crown to the bridge, and from the nut down to the crown behind it."""
    if stop_x is None:
        return 0.0
    c = float(preset.clearance_m(stop_x))
    if x_m >= stop_x:
        return -c * (length_m - x_m) / (length_m - stop_x)
    return -c * x_m / stop_x
