"""Why a coarse grid puts fretted notes out of tune: the held string's linearised modes.

A held note is, to first order, a linear system: the string's scheme on its grid (stiffness
h (T D^T D + E I (D^T D)^2) with the tuned T and E I, mass rho A h per node), the rigid frets on
both sides of the finger as equality constraints on their interpolants (both carry the pressed
string, see docs/engine.md), and the finger as a mass on its contact spring, linearised at the
pressing force, with its contact damping.  Of its modes within a semitone of the note, the one
that a pluck at 0.8 L drives and the pickup hears most (the finger's own, heavily damped
resonance mixes with some notes) gives the pitch; its frequency w of the semi-discrete system is
mapped through the explicit scheme's dispersion, (2 / k) asin(k w / 2).  Loss, Kirchhoff-Carrier
and the fretboard are left out: they move both grids alike.

The script prints, for every string and frets 1-12, that model's pitch on the grid of a quality
level minus its pitch on the reference grid of ``benchmarks.intonation`` (h <= 1.5 mm), next to
the same difference measured on rendered notes (``benchmarks.intonation``'s scene), and how far
the two agree.  The difference is the grid's share of the fretted-note error: it moves with where
the fret's and the finger's interpolants fall between the nodes, not steadily with the fret.

    python -m benchmarks.fret_modes [--preset steel-acoustic] [--quality draft]
"""

from __future__ import annotations

import argparse
import math
import time
from multiprocessing import Pool

import numpy as np
from scipy import linalg
from scipy.sparse import linalg as sparse_linalg

from benchmarks.intonation import FRETS, SR, print_table, table
from engine.controls import finger_x_m
from engine.guitar import QUALITY, Quality, oversample_for
from engine.kernels import interp
from engine.presets import Preset, get_preset
from engine.string import StringModel

PLUCK = 0.8  # benchmarks.intonation's pluck position, x / L

REFERENCE = Quality(max_h_m=1.5e-3, max_oversample=16)  # benchmarks.intonation's reference grid


def _interpolant(x: float, model: StringModel) -> np.ndarray:
    """j(x) over the interior nodes 1..N-1 (the kernel's interpolant, fixed ends dropped)."""
    p, w0, w1 = interp(x, model.h, model.n)
    j = np.zeros(model.n - 1)
    for node, w in ((p - 1, w0), (p, w1)):  # padded index -> node
        if w > 0.0:
            j[node - 1] = w
    return j


def held_frequency(model: StringModel, preset: Preset, fret: int, target: float) -> float:
    """Frequency (Hz) of the held note's mode on ``model``'s grid (see the module docstring)."""
    n, h, k = model.n, model.h, model.k
    d = (np.diag(-2.0 * np.ones(n - 1)) + np.diag(np.ones(n - 2), 1)
         + np.diag(np.ones(n - 2), -1)) / (h * h)
    fg = preset.finger
    # contact spring at the pressing force: F = K eta^alpha, so dF/deta = alpha F / eta
    eta = (fg.press_force_n / fg.stiffness) ** (1.0 / fg.alpha)
    kf = fg.alpha * fg.press_force_n / eta
    jf = np.append(_interpolant(finger_x_m(preset, fret), model), -1.0)  # string minus finger
    stiff = np.zeros((n, n))
    stiff[:-1, :-1] = h * (-model.tension_n * d + model.ei * d @ d)
    stiff += kf * np.outer(jf, jf)
    mass = np.diag(np.append(np.full(n - 1, model.rho_a * h), fg.mass_kg))
    frets = [preset.fret_x_m(q) for q in (fret, fret - 1) if q > 0]
    cons = np.array([np.append(_interpolant(x, model), 0.0) for x in frets]).T
    z = linalg.null_space(cons.T)
    # the finger's contact damping (which keeps its own resonance from ringing) makes the modes
    # complex: the quadratic eigenproblem (K + s C + s^2 M) u = 0 in first-order form
    m = z.T @ mass @ z
    nz = m.shape[0]
    eye, zero = np.eye(nz), np.zeros((nz, nz))
    a = np.block([[zero, eye], [-(z.T @ stiff @ z), -fg.damping_n_s_m * np.outer(z.T @ jf,
                                                                                  z.T @ jf)]])
    # the modes nearest the note (ARPACK, shift-invert about i w, w the semi-discrete frequency
    # that the scheme maps to the note)
    w = 2.0 / k * math.sin(k * math.pi * target)
    s_, v = sparse_linalg.eigs(a, k=6, M=np.block([[eye, zero], [zero, m]]), sigma=1j * w)
    up = s_.imag > 0.0
    u = z @ v[:nz, up]
    # the damped modes' frequencies, mapped through the scheme's dispersion
    f = 2.0 / k * np.arcsin(np.minimum(k * s_[up].imag / 2.0, 1.0)) / (2 * math.pi)
    # what the measurement hears: the mode's amplitude at the pluck times that at the pickup, per
    # unit modal mass; a mode mixed with the finger's own resonance is heard less
    pluck = np.append(_interpolant(PLUCK * model.length_m, model), 0.0)
    pickup = np.append(_interpolant(preset.pickup_position * model.length_m, model), 0.0)
    modal = np.abs(np.einsum("im,i,im->m", u, np.diag(mass), u))
    heard = np.abs((pluck @ u) * (pickup @ u)) / modal
    near = np.abs(1200.0 * np.log2(np.maximum(f, 1e-9) / target)) < 100.0
    if not near.any():
        return math.nan
    return float(f[near][np.argmax(heard[near])])


def predicted(preset: Preset, quality: Quality) -> np.ndarray:
    """The model's grid error (cents): the quality's grid against the reference grid."""
    err = np.zeros((preset.n_strings, len(FRETS)))
    for s, spec in enumerate(preset.strings, start=1):
        length = preset.string_length_m(s)
        _, coarse = oversample_for(spec, length, SR, quality)
        _, fine = oversample_for(spec, length, SR, REFERENCE)
        for i, q in enumerate(FRETS):
            target = spec.frequency_hz * 2.0 ** (q / 12.0)
            err[s - 1, i] = 1200.0 * math.log2(held_frequency(coarse, preset, q, target)
                                               / held_frequency(fine, preset, q, target))
    return err


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", default="steel-acoustic")
    ap.add_argument("--quality", default="draft", choices=list(QUALITY))
    args = ap.parse_args(argv)
    preset = get_preset(args.preset)
    quality = QUALITY[args.quality]
    t0 = time.perf_counter()
    model = predicted(preset, quality)
    with Pool(2) as pool:
        rendered = (table(args.preset, quality, False, pool)
                    - table(args.preset, REFERENCE, False, pool))
    grid = ", ".join(f"{oversample_for(s, preset.string_length_m(i), SR, quality)[1].h * 1e3:.2f}"
                     for i, s in enumerate(preset.strings, start=1))
    print(f"{args.preset}, quality '{args.quality}' (h in mm by string: {grid}) against the "
          f"reference grid (h <= 1.5 mm), cents, frets 1-12, finger {preset.finger.press_force_n} N")
    print_table("rendered notes: quality minus reference", rendered)
    print_table("linearised held string: quality minus reference", model)
    print_table("model minus rendered", model - rendered)
    ok = np.abs(model - rendered) <= 2.0
    print(f"model within 2 cents of the rendered grid error: {int(ok.sum())} of {ok.size} notes")
    print(f"\n({time.perf_counter() - t0:.0f} s on this machine)")


if __name__ == "__main__":
    main()
