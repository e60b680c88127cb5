"""Fretted-note intonation: cents from 12-TET for every string and frets 1-12.

A stiff string pressed onto a fret is sharper than the ideal shorter string (bending stiffness
carries across the fret, and pressing stretches the string); real guitars compensate by setting the
saddle back a few millimetres.  This script

1. measures the fretted error with no compensation on a fine reference grid (h <= 1.5 mm),
2. fits, per string, the saddle setback that minimises the largest error (exact ideal-string
   formula for the effect of a longer speaking length),
3. measures every quality level *with the preset's setbacks* and prints the tables.

    python -m benchmarks.intonation [--preset steel-acoustic] [--fit-only]

The presets' ``saddle_setback_m`` values come from step 2 of this script.
"""

from __future__ import annotations

import argparse
import time
from multiprocessing import Pool

import numpy as np

import engine
from engine.analysis import cents, decay_db_per_s, spectrum_peak
from engine.intonation import REFERENCE_H_M
from engine.options import QUALITY, Quality, RenderOptions
from engine.presets import get_preset
from engine.testing.scenes import SR, pluck, scene
from engine.testing.scenes import fret as fret_at

FRETS = tuple(range(1, 13))
# the fine reference grid (engine.intonation calibrates against the same spacing), uncalibrated
REFERENCE = Quality(max_h_m=REFERENCE_H_M, max_oversample=16)


def fretted_note(args) -> tuple[int, int, float, float]:
    """One fretted note (the finger with the preset's force, a 1 N pluck at 0.8 L): its pitch in
    cents from 12-TET, measured from 0.2 s, and the decay of its fundamental in dB/s."""
    preset_name, string, fret, quality, zero_setback = args
    guitar: dict = {"preset": preset_name}
    if zero_setback:
        n = get_preset(preset_name).n_strings
        guitar["strings"] = [{"string": s, "saddle_setback_m": 0.0} for s in range(1, n + 1)]
    events = [fret_at(string, fret, force=None),  # the engine's default force
              pluck(string, 0.05, force=1.0, position=0.8)]
    sc = scene(events, 1.2, guitar=guitar)
    audio = engine.render(sc, options=RenderOptions(quality=quality))
    target = get_preset(preset_name).strings[string - 1].frequency_hz * 2 ** (fret / 12)
    f = spectrum_peak(audio[int(0.2 * SR) :], SR, target, 0.08)
    return string, fret, float(cents(f, target)), decay_db_per_s(audio, SR, f)


def tables(preset_name: str, quality: Quality, zero_setback: bool,
           pool) -> tuple[np.ndarray, np.ndarray]:
    """Cents from 12-TET and decay (dB/s) of frets 1-12 on every string."""
    n = get_preset(preset_name).n_strings
    jobs = [(preset_name, s, q, quality, zero_setback) for s in range(1, n + 1) for q in FRETS]
    err = np.zeros((n, len(FRETS)))
    decay = np.zeros((n, len(FRETS)))
    for s, q, c, d in pool.map(fretted_note, jobs):
        err[s - 1, FRETS.index(q)] = c
        decay[s - 1, FRETS.index(q)] = d
    return err, decay


def table(preset_name: str, quality: Quality, zero_setback: bool, pool) -> np.ndarray:
    """Cents from 12-TET of frets 1-12 on every string."""
    return tables(preset_name, quality, zero_setback, pool)[0]


def print_table(title: str, err: np.ndarray, unit: str = "cents") -> None:
    print(f"\n{title}")
    print("string | " + " ".join(f"{q:>6d}" for q in FRETS) + " |  worst")
    for s, row in enumerate(err, start=1):
        worst = row[np.argmax(np.abs(row))]
        print(f"{s:>6d} | " + " ".join(f"{c:+6.1f}" for c in row) + f" | {worst:+6.1f}")
    print(f"all strings: worst {err.flat[np.argmax(np.abs(err))]:+.1f} {unit}")


def setback_effect(scale: float, setback: float) -> np.ndarray:
    """Cents a setback adds to frets 1-12 of an ideal string (relative to the open string)."""
    q = np.array(FRETS)
    ratio = (scale + setback) / (scale * 2.0 ** (-q / 12.0) + setback)
    return 1200.0 * np.log2(ratio) - 100.0 * q


def fit_setbacks(err: np.ndarray, scale: float) -> list[float]:
    grid = np.arange(0.0, 20e-3, 5e-5)
    best = []
    for row in err:
        worst = [np.max(np.abs(row + setback_effect(scale, d))) for d in grid]
        best.append(float(grid[int(np.argmin(worst))]))
    return best


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", default="steel-acoustic")
    ap.add_argument("--fit-only", action="store_true")
    args = ap.parse_args()
    preset = get_preset(args.preset)
    reference = REFERENCE
    t0 = time.perf_counter()
    with Pool(2) as pool:
        raw = table(args.preset, reference, True, pool)
        print_table(f"{args.preset}: no compensation, reference grid h <= 1.5 mm, "
                    f"finger {preset.finger.press_force_n:g} N or more (intonation.press_force) "
                    "(cents from 12-TET)", raw)
        fit = fit_setbacks(raw, preset.scale_length_m)
        print("\nsaddle setback that minimises the worst error (mm): "
              + ", ".join(f"string {s}: {d * 1e3:.2f}" for s, d in enumerate(fit, start=1)))
        predicted = raw + np.array([setback_effect(preset.scale_length_m, d) for d in fit])
        print_table("predicted with those setbacks (reference grid)", predicted)
        if not args.fit_only:
            current = [s.saddle_setback_m * 1e3 for s in preset.strings]
            print("\npreset's setbacks (mm): " + ", ".join(f"{d:.2f}" for d in current))
            for name, q in QUALITY.items():
                print_table(f"quality '{name}' with the preset's setbacks",
                            table(args.preset, q, False, pool))
            print_table("reference grid with the preset's setbacks",
                        table(args.preset, reference, False, pool))
    print(f"\n({time.perf_counter() - t0:.0f} s on this machine)")


if __name__ == "__main__":
    main()
