"""Fret interpolants calibrated on the grid, so that a fretted note has the pitch of a fine grid.

On a coarse grid (a plain string at 44.1 kHz has h = 8-10 mm, a large part of a fret spacing) a
fretted note comes out sharp by an amount that jumps from fret to fret: where the fret's and the
finger's interpolants (eq. (15)) fall between the nodes changes the held string's mode.  That error
is linear, and this module computes it.  The held note is modelled as

* the scheme's stiffness and mass on the grid, h (T D^T D + E I (D^T D)^2) and rho A h per node
  (the tuned T and E I of ``engine.fd.string.tune``), fixed and simply supported at both ends;
* the frets on both sides of the finger as equality constraints j_q^T u = 0 on their interpolants
  (a pressed string rests on both; docs/engine.md);
* the finger (eqs. (9)-(10)) as its mass on its contact spring, linearised at its pressing force
  (dF/d eta = alpha F / eta), with its contact damping, which keeps the finger's own resonance from
  ringing (without it, that resonance splits some notes into two modes);

and the note is its mode within a semitone of the target that a pluck at 0.8 L drives and the
pickup hears most, its frequency w mapped through the explicit scheme's dispersion, (2 / k)
asin(k w / 2).  Loss, Kirchhoff-Carrier and the fretboard are left out: they move every grid alike.
``benchmarks/fret_modes.py`` compares the model with rendered notes (docs/accuracy.md, "Fretted
notes on a coarse grid").

``fret_shifts`` moves each stopped fret's interpolant (not its height), and the finger that stops
it, along the string, towards the nut where the grid is sharp, until the model's note on the grid
has the pitch of the same note on a fine grid (h <= ``REFERENCE_H_M``, the reference of
``benchmarks/intonation.py``).  The same model gives the note's decay by the finger's damping,
which a coarse grid overstates (the sounding string reaches the nodes under the finger):
``finger_damping`` sets the contact damping of the finger stopping each fret so that the model's
note decays as on the fine grid, and ``fret_calibration`` refits the shift at that damping.

The same string at rest gives ``seating_force``: how hard the finger must press for the string to
rest on its fret at all (a lighter press leaves a dead or buzzing note), and ``press_force``, the
force a finger presses with when a scene does not say: the preset's, or more where the action is
higher than that force can overcome.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from functools import lru_cache, partial
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
from threadpoolctl import threadpool_limits

from .. import calibration_store
from ..performance import finger_x_m
from ..presets import Preset
from .kernels import interp
from .string import StringModel, tune

if TYPE_CHECKING:  # at run time, imported where a calibration is computed: a third of a second
    from scipy import sparse  # of import that a process finding them all in the store never needs

REFERENCE_H_M = 1.5e-3  # the fine grid that a calibrated grid's notes are matched to
PLUCK = 0.8  # x / L of the pluck whose response picks the note's mode (benchmarks.intonation's)
TOLERANCE_CENTS = 0.02  # a shift is refined until the model's note is this close to the reference
DECAY_TOLERANCE_DB_S = 0.25  # a finger's damping is refined until the note's decay is this close
# ... once the note's decay is this far from the fine grid's with the preset's damping (closer, the
# finger keeps it)
DECAY_CALIBRATE_DB_S = 1.0
DAMPING_RANGE = (1.0 / 256.0, 64.0)  # the finger's calibrated damping, times the preset's
# a finger that presses with no force of its own presses with at least this multiple of the
# seating force: the static force leaves the vibrating string no margin.  ``benchmarks/seating.py``
# (standard) prints rendered strings resting on their fret from at most 1.29 (steel) and 1.24
# (nylon) times it after a 4 N pluck, 1.13 and 1.11 after a 1 N pluck (docs/accuracy.md)
SEAT_MARGIN = 1.35


def _interpolant(x: float, model: StringModel) -> list[tuple[int, float]]:
    """j(x) as (interior node index 0..N-2, weight) pairs: the kernel's interpolant, with the
    weights on the fixed ends dropped."""
    p, w0, w1 = interp(x, model.h, model.n)
    return [(node - 1, w) for node, w in ((p - 1, w0), (p, w1)) if w > 0.0]


def _vector(pairs: list[tuple[int, float]], size: int) -> np.ndarray:
    v = np.zeros(size)
    for i, w in pairs:
        v[i] += w
    return v


def _null_basis(constraints: list[list[tuple[int, float]]], size: int) -> sparse.csr_matrix:
    """A sparse basis Z of {u : j^T u = 0 for every constraint j}: each constraint eliminates its
    node of largest weight, which then follows the nodes kept (u = Z u_kept)."""
    from scipy import sparse

    expr: dict[int, dict[int, float]] = {}  # eliminated node -> {kept node: coefficient}
    for pairs in constraints:
        row: dict[int, float] = {}
        for i, w in pairs:  # in terms of the nodes still kept
            for j, c in (expr[i].items() if i in expr else ((i, 1.0),)):
                row[j] = row.get(j, 0.0) + w * c
        row = {j: c for j, c in row.items() if c != 0.0}
        if not row:
            continue  # dependent on the constraints before it
        i = max(row, key=lambda j: abs(row[j]))
        sub = {j: -c / row[i] for j, c in row.items() if j != i}
        for e in expr.values():  # earlier eliminations that used node i
            if i in e:
                c = e.pop(i)
                for j, cj in sub.items():
                    e[j] = e.get(j, 0.0) + c * cj
        expr[i] = sub
    kept = [i for i in range(size) if i not in expr]
    col = {i: m for m, i in enumerate(kept)}
    rows, cols, vals = [], [], []
    for i in range(size):
        for j, c in (expr[i].items() if i in expr else ((i, 1.0),)):
            rows.append(i)
            cols.append(col[j])
            vals.append(c)
    return sparse.csr_matrix((vals, (rows, cols)), shape=(size, len(kept)))


@lru_cache(maxsize=64)
def _stiffness(model: StringModel, tension_ratio: float = 1.0) -> sparse.csc_matrix:
    """The string's stiffness h (T D^T D + E I (D^T D)^2) over nodes 1..N-1, its tension
    ``tension_ratio`` times the tuned one."""
    from scipy import sparse

    n, h = model.n, model.h
    d2 = sparse.diags([np.ones(n - 2), -2.0 * np.ones(n - 1), np.ones(n - 2)], [-1, 0, 1]) / h**2
    return (h * (-tension_ratio * model.tension_n * d2 + model.ei * (d2 @ d2))).tocsc()


@lru_cache(maxsize=64)
def _string_matrices(model: StringModel, finger_mass: float):
    """``_stiffness`` and the mass matrix over nodes 1..N-1 and the finger (its row and column of
    the stiffness empty): the same for every fret, so a calibration builds them once."""
    from scipy import sparse

    n, h = model.n, model.h
    stiff = sparse.block_diag([_stiffness(model), sparse.csr_matrix((1, 1))]).tocsr()
    mass = sparse.diags(np.append(np.full(n - 1, model.rho_a * h), finger_mass))
    return stiff, mass


def finger_spring(model: StringModel, preset: Preset, fret: int) -> float:
    """N/m: the finger's contact spring (eq. (9)) linearised at the force a finger with no force
    of its own presses ``fret`` with, dF/d eta = alpha F / eta; for alpha = 1 (every preset) it
    is K_FG whatever the force."""
    fg = preset.finger
    force = press_force(model, preset, fret)
    return fg.alpha * force / (force / fg.stiffness) ** (1.0 / fg.alpha)


class HeldNote(NamedTuple):
    frequency_hz: float  # through the scheme's dispersion, (2 / k) asin(k w / 2)
    decay_db_s: float  # of the mode's amplitude by the finger's contact damping (the string's own
    # loss is left out of the model), negative: dying


def held_note(model: StringModel, preset: Preset, fret: int, target: float,
              fret_x: float | None = None, prev_x: float | None = None,
              finger_x: float | None = None, damping: float | None = None) -> HeldNote:
    """The note the model above gives for ``fret`` on ``model``'s grid: the mode nearest
    ``target`` (Hz) that the pluck and the pickup hear most; NaNs if none is within a semitone.
    ``fret_x``, ``prev_x`` and ``finger_x`` place the interpolants of the fret, of the one behind
    it and of the finger (default: where they are, ``Preset.fret_x_m`` and
    ``controls.finger_x_m``); ``damping`` is the finger's contact damping (N s/m; default: the
    preset's)."""
    from scipy import sparse
    from scipy.sparse import linalg as sparse_linalg

    n, k = model.n, model.k
    size = n  # nodes 1..N-1 and the finger
    if fret_x is None:
        fret_x = float(preset.fret_x_m(fret, model.spec))
    if prev_x is None and fret > 1:
        prev_x = float(preset.fret_x_m(fret - 1, model.spec))
    if finger_x is None:
        finger_x = finger_x_m(preset, fret, model.spec)
    fg = preset.finger
    kf = finger_spring(model, preset, fret)
    jf = _vector(_interpolant(finger_x, model), size)
    jf[n - 1] = -1.0  # the spring stretches by (string under the finger) - (finger)
    string_stiff, mass = _string_matrices(model, fg.mass_kg)
    jfs = sparse.csr_matrix(jf)
    stiff = string_stiff + kf * (jfs.T @ jfs)
    damp = (fg.damping_n_s_m if damping is None else damping) * (jfs.T @ jfs)
    z = _null_basis([_interpolant(x, model) for x in (fret_x, prev_x) if x is not None], size)
    ks, cs, ms = (z.T @ a @ z for a in (stiff, damp, mass))
    nz = z.shape[1]
    eye = sparse.identity(nz)
    a = sparse.bmat([[None, eye], [-ks, -cs]], format="csc").astype(complex)
    b = sparse.block_diag([eye, ms], format="csc").astype(complex)
    w = 2.0 / k * math.sin(min(k * math.pi * target, 0.5 * math.pi))  # maps to the target
    # a fixed start vector: ARPACK's default is random, and the shifts (so the audio) would differ
    # in the last bits from one process to the next.  tol 1e-10 instead of machine precision
    # saves iterations; the shifts of frets 1-12 of the steel and nylon sets at draft and
    # standard came out the same to the last bit
    start = np.ones(2 * nz, complex)
    s, v = sparse_linalg.eigs(a, k=min(6, 2 * nz - 2), M=b, sigma=1j * w, v0=start, tol=1e-10)
    up = s.imag > 0.0
    u = z @ v[:nz, up]
    f = 2.0 / k * np.arcsin(np.minimum(k * s[up].imag / 2.0, 1.0)) / (2.0 * math.pi)
    pluck = _vector(_interpolant(PLUCK * model.length_m, model), size)
    pickup = _vector(_interpolant(preset.pickup_position * model.length_m, model), size)
    modal = np.abs(np.einsum("im,i,im->m", u, mass.diagonal(), u))
    heard = np.abs((pluck @ u) * (pickup @ u)) / modal
    near = np.abs(1200.0 * np.log2(np.maximum(f, 1e-9) / target)) < 100.0
    if not near.any():
        return HeldNote(math.nan, math.nan)
    i = np.flatnonzero(near)[np.argmax(heard[near])]
    return HeldNote(float(f[i]), float(20.0 / math.log(10.0) * s[up][i].real))


@lru_cache(maxsize=4096)
def seating_force(model: StringModel, preset: Preset, fret: int,
                  tension_ratio: float = 1.0) -> float:
    """``seating_force_of``, cached per process and on disk per machine (``calibration_store``)."""
    return calibration_store.recall(
        "seating_force", (model, preset, fret, tension_ratio),
        lambda: (seating_force_of(model, preset, fret, tension_ratio),))[0]


def seating_force_of(model: StringModel, preset: Preset, fret: int,
                     tension_ratio: float = 1.0) -> float:
    """Newtons: the least force with which a finger stopping ``fret`` (where
    ``controls.finger_x_m`` puts it) holds the string at rest on that fret, the string's tension
    ``tension_ratio`` times its tuned one (a bend raises it, and with it this force).

    Statics of the string on ``model``'s grid (its stiffness, ``_stiffness``): the rest line
    runs from the nut to the saddle, the fret tips are their clearance below it
    (``Preset.clearance_m``; the nut is on the line), and the finger pushes down with F at its
    interpolant while the string rests on ``fret`` and on the fret behind it.  The supports'
    reactions are affine in F; the one on ``fret``, a F + b, is negative for a light press (the
    string would have to be pulled down onto the fret), and the force is the F at which it reaches
    zero.  A fret can only push: where the fret behind would have to pull at that force (near the
    nut, which stands above the frets, the pressed string leaves it), the string is solved again
    without it.  A vibrating string needs more (``SEAT_MARGIN``)."""
    from scipy.sparse import linalg as sparse_linalg

    n = model.n
    lu = sparse_linalg.splu(_stiffness(model, tension_ratio))
    finger = _vector(_interpolant(finger_x_m(preset, fret, model.spec), model), n - 1)
    frets = [fret - 1, fret] if fret > 1 else [fret]
    while True:
        xs = [float(preset.fret_x_m(q, model.spec)) for q in frets]
        j = np.column_stack([_vector(_interpolant(x, model), n - 1) for x in xs])
        heights = -np.asarray(preset.clearance_m(np.array(xs)), dtype=float)
        solved = lu.solve(np.column_stack([finger, j]))
        # u = K^-1 (-F j_f + J R) with J^T u = heights: G R = heights + F c, R = b + a F
        gram = j.T @ solved[:, 1:]
        try:
            b = np.linalg.solve(gram, heights)
            a = np.linalg.solve(gram, j.T @ solved[:, 0])
        except np.linalg.LinAlgError:  # both supports on the same nodes: the grid cannot tell
            return 0.0
        if b[-1] >= 0.0 or a[-1] <= 0.0:
            return 0.0
        force = -b[-1] / a[-1]
        if len(frets) == 1 or b[0] + a[0] * force >= 0.0:
            return float(force)
        frets = [fret]  # the fret behind would pull: the string does not rest on it


def press_force(model: StringModel, preset: Preset, fret: int,
                tension_ratio: float = 1.0) -> float:
    """The force a finger stopping ``fret`` presses with when the scene gives none: the preset's
    (``FingerSpec.press_force_n``), or ``SEAT_MARGIN`` times the seating force at the highest
    tension the scene gives the string (``tension_ratio``: its bends) where that is more (the high
    frets, where the action is highest, the first, where the nut stands above the frets, and a
    bent string)."""
    if fret < 1:
        return preset.finger.press_force_n
    return max(preset.finger.press_force_n,
               SEAT_MARGIN * seating_force(model, preset, fret, tension_ratio))


@lru_cache(maxsize=64)
def reference_model(model: StringModel) -> StringModel:
    """The same string tuned on the fine grid (h <= ``REFERENCE_H_M``): the internal rate raised
    by the smallest integer factor that gets there.  Cached: every fret of a string asks for it,
    and each factor tried is a tuning."""
    factor = 1
    while True:
        fine = tune(model.spec, model.length_m, factor / model.k)
        if fine.h <= REFERENCE_H_M or factor >= 64:
            return fine
        factor += 1


@lru_cache(maxsize=4096)
def reference_note(model: StringModel, preset: Preset, fret: int) -> HeldNote:
    """The note at ``fret`` on the fine grid of ``model``'s string (``reference_model``): what the
    calibration of that fret matches, in pitch and in decay.  Cached: the fine grid's solve is
    most of a calibration's cost."""
    target = model.spec.frequency_hz * 2.0 ** (fret / 12.0)
    return held_note(reference_model(model), preset, fret, target)


def _illinois(f, a: float, fa: float, b: float, fb: float, tol: float, best: tuple[float, float]):
    """Regula falsi with the Illinois rule on f, bracketed by a and b (f(a) f(b) <= 0): the x
    whose |f| is smallest of those tried (``best``: the (x, f) to beat), once |f| <= tol or
    after 30 steps."""
    for _ in range(30):
        c = b - fb * (b - a) / (fb - fa)
        fc = f(c)
        if not math.isfinite(fc):
            break
        if abs(fc) < abs(best[1]):
            best = (c, fc)
        if abs(fc) <= tol:
            break
        if fc * fb < 0.0:
            a, fa = b, fb
        else:  # the same end kept twice: halve its value (Illinois)
            fa *= 0.5
        b, fb = c, fc
    return best


@lru_cache(maxsize=4096)
def fret_shift(model: StringModel, preset: Preset, fret: int, damping: float | None = None) -> float:
    """Metres to move the interpolants of ``fret`` and of the finger stopping it, together
    (towards the bridge if positive), so that the model's note at that fret on ``model``'s grid has
    the pitch it has on the fine grid.  Moving the finger with the fret keeps the distance between
    them, which sets how a tap or a pressed finger drives the string.

    The fret behind stays where it is in the model (each fret is calibrated on its own, so a scene
    calibrates only the frets it stops).  The shift is searched in steps of h / 8 in the direction
    that corrects the error, at most h / 2 and no further than half way to the next fret (the
    finger: to the fret behind it), then refined by regula falsi (Illinois) to
    ``TOLERANCE_CENTS``; if no shift within those bounds reaches the fine grid's pitch, the one that
    comes closest is taken.  ``damping``: the finger's contact damping on ``model``'s grid (default:
    the preset's; the fine grid keeps the preset's).  Cached per process.
    """
    spec = model.spec
    target = spec.frequency_hz * 2.0 ** (fret / 12.0)
    want = reference_note(model, preset, fret).frequency_hz
    x0 = float(preset.fret_x_m(fret, spec))
    xf = finger_x_m(preset, fret, spec)

    def err(d: float) -> float:
        f = held_note(model, preset, fret, target, fret_x=x0 + d, finger_x=xf + d,
                      damping=damping).frequency_hz
        return 1200.0 * math.log2(f / want) if f > 0.0 else math.nan

    e0 = err(0.0)
    if not math.isfinite(want) or not math.isfinite(e0) or abs(e0) <= TOLERANCE_CENTS:
        return 0.0
    if e0 > 0.0:  # sharp: a longer speaking length, towards the nut
        limit = min(0.5 * model.h, 0.5 * (xf - float(preset.fret_x_m(fret - 1, spec))))
        sign = -1.0
    else:
        nxt = float(preset.fret_x_m(fret + 1, spec)) if fret < preset.frets else model.length_m
        limit = min(0.5 * model.h, 0.5 * (nxt - x0))
        sign = 1.0
    best, ebest = 0.0, e0
    a, ea = 0.0, e0
    step = model.h / 8.0
    d = 0.0
    while abs(d) < limit:
        d = sign * min(abs(d) + step, limit)
        e = err(d)
        if not math.isfinite(e):
            break
        if abs(e) < abs(ebest):
            best, ebest = d, e
        if e * ea <= 0.0:  # bracketed between a and d
            best, ebest = _illinois(err, a, ea, d, e, TOLERANCE_CENTS, (best, ebest))
            break
        a, ea = d, e
    return best


@lru_cache(maxsize=4096)
def finger_damping(model: StringModel, preset: Preset, fret: int, shift: float = 0.0) -> float:
    """N s/m: the contact damping of a finger stopping ``fret`` on ``model``'s grid (its fret and
    finger moved by ``shift``, ``fret_shift``) with which the model's note decays as the same note
    does on the fine grid with the preset's damping.

    On a coarse grid the sounding string reaches the nodes under the finger (the fret's
    interpolant pins a point between two nodes, and the stencil couples nodes two apart), so the
    finger's damping drains the note (``benchmarks/fret_modes.py``).  Where the note lies above the
    finger's own resonance (its mass on its contact spring: 318 Hz for the guitars' fingers, 252 Hz
    for the bass's) less damping drains less; near and below it the finger rides the string, and
    more damping holds it still and drains less, but less damping may also match (the finger's
    resonance then takes part in the note).  The search starts at the preset's damping, goes that
    way (down above the resonance, up below it; the other way where the grid drains less than the
    fine grid) in factors of 2 up to ``DAMPING_RANGE``, refines the first bracket by regula falsi
    (on the log of the damping) to ``DECAY_TOLERANCE_DB_S``, then searches the other way no
    further out: the root nearest the preset's damping is taken (on the nylon set's string 3 at
    frets 1-2 the roots far above rendered further from the fine grid than the model said, the
    ones below near it: ``benchmarks/fret_modes.py``).  A note within ``DECAY_CALIBRATE_DB_S`` of
    the fine grid, or one for which no damping in the range brackets the fine grid's decay, keeps
    the preset's damping.  Any damping >= 0 keeps the energy balance exact (it is booked as a
    loss).  Cached per process."""
    r0 = preset.finger.damping_n_s_m
    spec = model.spec
    target = spec.frequency_hz * 2.0 ** (fret / 12.0)
    want = reference_note(model, preset, fret).decay_db_s
    x0 = float(preset.fret_x_m(fret, spec)) + shift
    xf = finger_x_m(preset, fret, spec) + shift

    def err(log_scale: float) -> float:
        d = held_note(model, preset, fret, target, fret_x=x0, finger_x=xf,
                      damping=r0 * math.exp(log_scale)).decay_db_s
        return d - want

    e0 = err(0.0)
    if not math.isfinite(want) or not math.isfinite(e0) or abs(e0) <= DECAY_CALIBRATE_DB_S:
        return r0
    lo, hi = (math.log(v) for v in DAMPING_RANGE)
    step = math.log(2.0)
    # above the finger's resonance (its mass on its contact spring, linearised at its force as in
    # ``held_note``) less damping drains less; near and below it more damping holds the finger
    # still
    resonance = math.sqrt(finger_spring(model, preset, fret) / preset.finger.mass_kg) / (
        2.0 * math.pi)
    direction = -1.0 if target > resonance else 1.0
    if e0 > 0.0:  # the grid drains less than the fine grid: the other way
        direction = -direction
    # the root nearest the preset's damping (in its log): that way first, then the other way no
    # further out than a root found already
    root = None
    for way in (direction, -direction):
        bound = (hi if way > 0.0 else lo) if root is None else way * abs(root)
        a, ea = 0.0, e0
        while way * (bound - a) > 1e-12:
            b = a + way * min(step, way * (bound - a))
            eb = err(b)
            if not math.isfinite(eb):
                break
            if eb * ea <= 0.0:
                best = (b, eb) if abs(eb) < abs(ea) else (a, ea)
                root = _illinois(err, a, ea, b, eb, DECAY_TOLERANCE_DB_S, best)[0]
                break
            a, ea = b, eb
    return r0 if root is None else r0 * math.exp(root)


class FretCalibration(NamedTuple):
    shift_m: float  # ``fret_shift``: the fret's and its finger's interpolants moved this far
    damping_n_s_m: float  # ``finger_damping``: the contact damping of a finger stopping it


@lru_cache(maxsize=4096)
def fret_calibration(model: StringModel, preset: Preset, fret: int) -> FretCalibration:
    """Pitch and decay of the note at ``fret`` on ``model``'s grid matched to the fine grid's: the
    shift at the preset's damping, the damping at that shift, then the shift again at that damping
    (the damping moves the note's pitch by up to a few cents where the note is near the finger's
    resonance).  Cached per process, and on disk per machine (``calibration_store``)."""

    def compute() -> FretCalibration:
        shift = fret_shift(model, preset, fret)
        damping = finger_damping(model, preset, fret, shift)
        if damping != preset.finger.damping_n_s_m:
            shift = fret_shift(model, preset, fret, damping)
        return FretCalibration(shift, damping)

    return FretCalibration(*calibration_store.recall("fret_calibration", (model, preset, fret),
                                                     compute))


@lru_cache(maxsize=4096)
def _stored_shift(model: StringModel, preset: Preset, fret: int) -> float:
    """``fret_shift`` at the preset's damping, kept on disk per machine (``calibration_store``)."""
    return calibration_store.recall("fret_shift", (model, preset, fret),
                                    lambda: (fret_shift(model, preset, fret),))[0]


def _each_fret(preset: Preset, frets: Iterable[int], calibrate) -> dict:
    """``calibrate(q)`` of each of ``frets`` (those the scene's fingers stop) on the preset's
    fretboard, with BLAS on one thread: the solves are small, and OpenBLAS's own threads, one set
    per process, fought over the cores when two worker processes calibrated at once (the soak's
    random scenes ran many times slower than one at a time)."""
    wanted = sorted(q for q in set(frets) if 1 <= q <= preset.frets)
    if not wanted:
        return {}
    with threadpool_limits(limits=1, user_api="blas"):
        return {q: calibrate(q) for q in wanted}


def fret_calibrations(model: StringModel, preset: Preset,
                      frets: Iterable[int]) -> dict[int, FretCalibration]:
    """``fret_calibration`` of each of ``frets``."""
    return _each_fret(preset, frets, partial(fret_calibration, model, preset))


def fret_shifts(model: StringModel, preset: Preset, frets: Iterable[int]) -> dict[int, float]:
    """``fret_shift`` (at the preset's damping) of each of ``frets``."""
    return _each_fret(preset, frets, partial(_stored_shift, model, preset))
