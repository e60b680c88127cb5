"""The waveguide model against the finite-difference model: cost and error on the same scenes.

    python -m benchmarks.waveguide [--full] [--intonation]

Steel-acoustic preset, 44.1 kHz, no body (the strings' own sound).  For each scene it renders

* ``wg``: the waveguide (``"model": "waveguide"``, engine/waveguide);
* ``fd``: the finite-difference model at quality ``standard``;
* ``ref``: the finite-difference reference: quality ``high`` (h <= 2.5 mm, partials within 0.3
  cents of the stiff string), or, with ``--full``, every string at 8x oversampling;

and prints

* cost: CPU seconds of the rendering thread for the whole render (preparation and blocks; each
  scene rendered once before, so that compiled kernels and per-process caches are warm; the least
  of three runs), as "x real time" (audio seconds per CPU second, one core), and the
  waveguide's speed-up over ``fd``;
* pitch (cents) of the fundamental against 12-TET, for ``wg``, ``fd`` and ``ref``;
* decay (dB/s) of the fundamental (``engine.analysis.decay_db_per_s``) of ``wg`` and ``fd`` minus
  that of ``ref``;
* spectral error (dB) of ``wg`` and ``fd`` against ``ref``: 20 log10 of the relative distance of
  STFT magnitudes, 20 Hz - 14 kHz (``benchmarks.pareto.spectral_error_db``); 0 dB is an error as
  large as the signal.

Scenes: every open string (1 N pluck at 0.8, 1.2 s), fretted notes on every string (a 3 N finger,
frets 1, 5 and 12; 1-12 with ``--full``), and the fretted six-string C major strum (C/G shape
3-3-2-0-1-0, 2 N, 4 s), whose cost is the issue's aim (the waveguide at least 20x cheaper than
``fd`` with fretted pitch within 3 cents).  ``--intonation`` adds the waveguide's fretted pitch
with ``intonation="physical"`` (``engine.waveguide.fingering``).

Where each model is better (as the script printed on a shared two-core virtual machine, AMD EPYC,
with a callgrind count running beside it; the cost columns move with the machine's speed, which
on such a machine varies by tens of per cent from minute to minute, hence the strum's rounds):

* cost: the waveguide.  Single notes at a median 313x real time against the finite-difference
  model's 19.7x at ``standard``; the fretted C/G strum 109x against 5.0x real time, 21.1x cheaper
  (the median of seven rounds' ratios, which ranged 15.2-30.6x).
  ``python -m tools.instructions --waveguide`` counts the strum's instructions, which do not move
  with the machine: 59.6 million per second of audio against 1000.1 million at ``standard``,
  16.8x fewer.  What is left of the waveguide's cost is the loop's own work per
  sample (the termination's Lagrange read, loss and allpass sections, the bridge, a pickup), the
  general steps while a pluck's junction leaks what it put on the string (64 ms a pluck), the
  checks of the collision points a fretted string's vibration keeps within reach for its first
  second and their reach bounds, the glide's slope sums, and the Python around each block
  (``engine/waveguide/kernel.py``).
* glide of hard plucks: the two differ in the first 25 ms and agree after.  After a 20 N pick
  or pop the waveguide glides less at first (string 2: +8.4 against +57.8 cents after a pick,
  +163.0 against +399.1 after a pop, 5-25 ms), after a 20 N slap alike (+5.0 against +8.5); from
  25 ms on the two agree within 6.2 cents.  The waveguide's glide reads the string's slope on its
  grid, where a pluck's contact is a point junction; the finite-difference string's distributed
  Kirchhoff-Carrier term sees the pluck's whole shape.
* pitch: the waveguide, by construction.  Its fractional delay puts open strings within 0.09 cents
  and stopped strings (ideal intonation) within 0.07 cents of 12-TET, where the finite-difference
  model sounds the physics of its frets: -0.67..+0.49 cents at ``standard`` at frets 1, 5 and 12
  (its converged reference -0.80..+1.35), compensated by the presets' saddle setbacks and nut
  compensations.  With ``--intonation`` the waveguide's own physical model of the stopped
  string, its frets placed from each string's compensated nut as the finite-difference model
  places them, gives -0.6..+0.2 cents at frets 1-12 of the steel set: the presets'
  compensations, fitted to the finite-difference physics, tune this model too.
* decay of the fundamental: both fitted to the same T60 values, and the waveguide's fingering
  termination to the finite-difference finger's damping of the held note
  (``engine.waveguide.fingering``).  Open strings agree with the reference to 0.01 dB/s; fretted
  notes within 2.2 dB/s on the waveguide and 2.4 dB/s on the finite-difference model at
  ``standard`` (both worst on string 1 at fret 12).
* spectrum: the finite-difference model (it is the reference's own scheme): median -17.9 dB
  against -8.7 dB for the waveguide, whose worst notes (-0.9 to -4.4 dB) are the wound strings
  stopped by a finger, where the finite-difference string's contact with the finger and the
  frets shapes the upper partials and the waveguide's rigid crown does not.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

import engine
from benchmarks.pareto import spectral_error_db
from engine.analysis import cents, decay_db_per_s, spectrum_peak
from engine.models import PRESSED_STRING
from engine.options import QUALITY, RenderOptions
from engine.testing.scenes import CG_CHORD, SR, fret, pluck, scene, strum_scene
from engine.waveguide import WaveguideOptions, prepare
from engine.waveguide import render as wg_render

STEEL = engine.get_preset("steel-acoustic")
CHORD = CG_CHORD


REPEAT = 3  # timed runs of each render; the least CPU time counts (the machine's load only adds)


def cpu(fn) -> tuple[float, np.ndarray]:
    """The least CPU time of ``REPEAT`` runs of fn, after one untimed run (compiled kernels,
    per-process caches), and its output."""
    out = fn()
    best = math.inf
    for _ in range(REPEAT):
        t = time.thread_time()
        out = fn()
        best = min(best, time.thread_time() - t)
    return best, out


def renderer(sc: dict, model: str, options=None):
    if model == "wg":
        parsed = engine.parse_scene({**sc, "model": "waveguide"})
        return lambda: wg_render(parsed, options, statics=PRESSED_STRING)
    opts = options or RenderOptions()
    return lambda: engine.render({**sc, "output": {"body": "none", "normalize": False}},
                                 options=opts) / engine.FIXED_GAIN


def reference_options(full: bool) -> RenderOptions:
    return RenderOptions(oversample=8) if full else RenderOptions(quality=QUALITY["high"])


def pitch(a: np.ndarray, f: float) -> float:
    return float(cents(spectrum_peak(a[int(0.2 * SR):], SR, f, 0.08), f))


def note_row(name: str, sc: dict, f: float, ref_opts: RenderOptions) -> dict:
    t_wg, wg = cpu(renderer(sc, "wg"))
    t_fd, fd = cpu(renderer(sc, "fd"))
    ref = renderer(sc, "ref", ref_opts)()
    d_ref = decay_db_per_s(ref, SR, f)
    dur = sc["duration"]
    return {"scene": name, "x_wg": dur / t_wg, "x_fd": dur / t_fd,
            "c_wg": pitch(wg, f), "c_fd": pitch(fd, f), "c_ref": pitch(ref, f),
            "d_wg": decay_db_per_s(wg, SR, f) - d_ref, "d_fd": decay_db_per_s(fd, SR, f) - d_ref,
            "s_wg": spectral_error_db(wg, ref), "s_fd": spectral_error_db(fd, ref)}


def print_rows(title: str, rows: list[dict]) -> None:
    print(f"\n{title}")
    print(f"{'scene':14s} | {'x real time':>15s} | {'cents vs 12-TET':>22s} | "
          f"{'decay - ref dB/s':>16s} | {'spectral dB':>12s}")
    print(f"{'':14s} | {'wg':>7s} {'fd':>7s} | {'wg':>6s} {'fd':>7s} {'ref':>7s} | "
          f"{'wg':>7s} {'fd':>8s} | {'wg':>5s} {'fd':>6s}")
    for r in rows:
        print(f"{r['scene']:14s} | {r['x_wg']:7.0f} {r['x_fd']:7.1f} | {r['c_wg']:+6.2f} "
              f"{r['c_fd']:+7.2f} {r['c_ref']:+7.2f} | {r['d_wg']:+7.2f} {r['d_fd']:+8.2f} | "
              f"{r['s_wg']:5.1f} {r['s_fd']:6.1f}")


GLIDE_WINDOWS = ((0.005, 0.025), (0.025, 0.05), (0.05, 0.1), (0.4, 0.6))  # s after the pluck
GLIDE_PLUCKS = (("pick", 8.0), ("pick", 20.0), ("slap", 20.0), ("pop", 20.0))


def glide_rows() -> list[tuple[str, list[float], list[float]]]:
    """The pitch glide of hard plucks: the fundamental's pitch (cents from nominal) in each of
    ``GLIDE_WINDOWS`` after a pluck of each of ``GLIDE_PLUCKS`` on open strings 1, 2 and 3, on
    the waveguide and on the finite-difference model at ``standard`` (the peak searched within
    half the frequency either way: a glide can be large, and the second partial stays outside;
    the wound strings are left out, as the first window holds too few of their periods)."""
    rows = []
    for s in (1, 2, 3):
        f = STEEL.strings[s - 1].frequency_hz
        for style, force in GLIDE_PLUCKS:
            sc = scene([pluck(s, force=force, style=style)], 0.6)
            out = []
            for model in ("wg", "fd"):
                a = renderer(sc, model)()
                out.append([float(cents(spectrum_peak(a[int(t0 * SR):int(t1 * SR)], SR, f, 0.5),
                                        f)) for t0, t1 in GLIDE_WINDOWS])
            rows.append((f"string {s} {style} {force:g} N", *out))
    return rows


STRUM_ROUNDS = 7  # the strum's rounds: each times both models, one after the other


def strum(ref_opts: RenderOptions) -> dict:
    """The strum on both models, timed in ``STRUM_ROUNDS`` rounds that each render the
    waveguide and then the finite-difference model once (after an untimed render of each): the
    speed-up is the median of the rounds' ratios, each taken from two renders seconds apart, so
    that a change of the machine's speed between rounds (a shared virtual machine's varies by
    tens of per cent from minute to minute) moves both sides of a ratio alike; the spread of the
    ratios is printed with it."""
    sc = strum_scene()
    run_wg, run_fd = renderer(sc, "wg"), renderer(sc, "fd")
    wg, fd = run_wg(), run_fd()
    times = []
    for _ in range(STRUM_ROUNDS):
        t = time.thread_time()
        run_wg()
        t_wg = time.thread_time() - t
        t = time.thread_time()
        run_fd()
        times.append((t_wg, time.thread_time() - t))
    ratios = sorted(t_fd / t_wg for t_wg, t_fd in times)
    t_wg = float(np.median([t for t, _ in times]))
    t_fd = float(np.median([t for _, t in times]))
    ref = renderer(sc, "ref", ref_opts)()
    # each string's pitch: the chord's notes are all different, so each is its own peak
    notes = {s: STEEL.strings[s - 1].frequency_hz * 2 ** (q / 12) for s, q in CHORD.items()}
    c_wg = {s: pitch(wg, f) for s, f in notes.items()}
    c_fd = {s: pitch(fd, f) for s, f in notes.items()}
    return {"x_wg": 4.0 / t_wg, "x_fd": 4.0 / t_fd, "speedup": float(np.median(ratios)),
            "ratio_lo": ratios[0], "ratio_hi": ratios[-1],
            "s_wg": spectral_error_db(wg, ref), "s_fd": spectral_error_db(fd, ref),
            "c_wg": c_wg, "c_fd": c_fd}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--full", action="store_true", help="frets 1-12, an x8 reference")
    ap.add_argument("--intonation", action="store_true",
                    help="also the waveguide's physical intonation, frets 1-12")
    args = ap.parse_args()
    ref_opts = reference_options(args.full)
    ref_name = "x8 oversampling" if args.full else "quality high"
    print(f"steel-acoustic, 44.1 kHz, no body; reference: the finite-difference model at {ref_name}")
    rows = []
    for s in range(1, 7):
        f = STEEL.strings[s - 1].frequency_hz
        rows.append(note_row(f"open {s}", scene([pluck(s)], 1.2), f, ref_opts))
    print_rows("open strings (1 N pluck at 0.8)", rows)
    frets = range(1, 13) if args.full else (1, 5, 12)
    frow = []
    for s in range(1, 7):
        for q in frets:
            f = STEEL.strings[s - 1].frequency_hz * 2 ** (q / 12)
            frow.append(note_row(f"string {s} fret {q}",
                                 scene([fret(s, q), pluck(s, time=0.05)], 1.2), f, ref_opts))
    print_rows("fretted notes (3 N finger, 1 N pluck)", frow)
    st = strum(ref_opts)
    print("\nfretted C/G strum (3-3-2-0-1-0, 2 N, 4 s), one core")
    print(f"  waveguide {st['x_wg']:.0f}x real time, finite difference (standard) "
          f"{st['x_fd']:.1f}x (medians of {STRUM_ROUNDS} rounds): the waveguide is "
          f"{st['speedup']:.1f}x cheaper (median of the rounds' ratios; they range "
          f"{st['ratio_lo']:.1f}-{st['ratio_hi']:.1f}x)")
    print(f"  spectral error against the reference: waveguide {st['s_wg']:.1f} dB, "
          f"finite difference {st['s_fd']:.1f} dB")
    print("  pitch of each string in the chord (cents vs 12-TET), waveguide / finite difference: "
          + ", ".join(f"{s}: {st['c_wg'][s]:+.2f} / {st['c_fd'][s]:+.2f}" for s in CHORD))
    print("\npitch glide of hard plucks on open strings (cents from nominal), waveguide / finite "
          "difference (standard)")
    print(f"{'pluck':22s} | " + " | ".join(f"{1000 * t0:.0f}-{1000 * t1:.0f} ms".rjust(15)
                                            for t0, t1 in GLIDE_WINDOWS))
    for name, wg, fd in glide_rows():
        print(f"{name:22s} | " + " | ".join(f"{a:+7.1f} {b:+7.1f}" for a, b in zip(wg, fd,
                                                                             strict=True)))
    if args.intonation:
        print("\nwaveguide fretted pitch with intonation='physical' (cents vs 12-TET, frets 1-12)")
        opts = WaveguideOptions(intonation="physical")
        for s in range(1, 7):
            errs = []
            for q in range(1, 13):
                f = STEEL.strings[s - 1].frequency_hz * 2 ** (q / 12)
                sc = engine.parse_scene({**scene([fret(s, q), pluck(s, time=0.05)], 1.2),
                                         "model": "waveguide"})
                inst = prepare(sc, opts, statics=PRESSED_STRING)
                a = np.concatenate(list(inst.blocks()))
                errs.append(pitch(a, f))
            print(f"  string {s}: " + " ".join(f"{e:+.1f}" for e in errs))
    allrows = rows + frow
    worst_wg = max(abs(r["c_wg"]) for r in frow)
    worst_fd = max(abs(r["c_fd"]) for r in frow)
    print("\nsummary")
    print(f"  fretted pitch, worst |cents| vs 12-TET: waveguide {worst_wg:.2f}, "
          f"finite difference (standard) {worst_fd:.2f}, reference "
          f"{max(abs(r['c_ref']) for r in frow):.2f}")
    print(f"  decay of the fundamental, worst |wg - ref| {max(abs(r['d_wg']) for r in allrows):.1f}"
          f" dB/s, |fd - ref| {max(abs(r['d_fd']) for r in allrows):.1f} dB/s")
    print(f"  spectral error, median: waveguide {np.median([r['s_wg'] for r in allrows]):.1f} dB, "
          f"finite difference {np.median([r['s_fd'] for r in allrows]):.1f} dB")
    print(f"  cost, median x real time per note: waveguide "
          f"{np.median([r['x_wg'] for r in allrows]):.0f}, finite difference "
          f"{np.median([r['x_fd'] for r in allrows]):.1f}")


if __name__ == "__main__":
    main()
