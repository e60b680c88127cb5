"""Fretted-note intonation: cents from 12-TET for every string and frets 1-12 (and above).

A stiff string pressed onto a fret is sharper than the ideal shorter string (bending stiffness
carries across the fret, and pressing stretches the string); real guitars compensate at the saddle
(set back a few millimetres) and at the nut (moved a little towards the frets).  The error has an
offset (fret 1 is already sharp: the stretch of pressing) and a part that grows up the neck (the
stiffness, which grows as the speaking length shortens): the nut compensation flattens every fret
alike, the setback more the higher the fret, so together they cancel both.  This script

1. measures the fretted error with no compensation on a fine reference grid (h <= 1.5 mm), on
   every fret of the preset,
2. fits, per string, the saddle setback and nut compensation that minimise the largest error over
   the whole fretboard (exact ideal-string formula for the effect of both on the speaking lengths),
3. measures every quality level and the reference grid *with the preset's compensation* on every
   fret and prints the tables (frets 1-12 and the frets above apart).

    python -m benchmarks.intonation [--preset steel-acoustic] [--fit-only]
    python -m benchmarks.intonation --above-12th standard   # frets 13 and up, one quality

The presets' ``saddle_setback_m`` and ``nut_compensation_m`` values come from step 2.
"""

from __future__ import annotations

import argparse
import time
from multiprocessing import Pool

import numpy as np

import engine
from engine.analysis import cents, decay_db_per_s, spectrum_peak
from engine.fd.intonation import REFERENCE_H_M
from engine.options import QUALITY, Quality, RenderOptions
from engine.presets import PRESETS, get_preset
from engine.scene import MAX_NUT_COMPENSATION_M
from engine.testing.scenes import SR, pluck, scene
from engine.testing.scenes import fret as fret_at

FRETS = tuple(range(1, 13))
# the fine reference grid (engine.fd.intonation calibrates against the same spacing), uncalibrated
REFERENCE = Quality(max_h_m=REFERENCE_H_M, max_oversample=16)


def fretted_note(args) -> tuple[int, int, float, float]:
    """One fretted note (the finger with the preset's force, a 1 N pluck at 0.8 L): its pitch in
    cents from 12-TET, measured from 0.2 s, and the decay of its fundamental in dB/s.  With
    ``uncompensated`` every string has no saddle setback and no nut compensation."""
    preset_name, string, fret, quality, uncompensated = args
    guitar: dict = {"preset": preset_name}
    if uncompensated:
        n = get_preset(preset_name).n_strings
        guitar["strings"] = [{"string": s, "saddle_setback_m": 0.0, "nut_compensation_m": 0.0}
                             for s in range(1, n + 1)]
    events = [fret_at(string, fret, force=None),  # the engine's default force
              pluck(string, 0.05, force=1.0, position=0.8)]
    sc = scene(events, 1.2, guitar=guitar)
    audio = engine.render(sc, options=RenderOptions(quality=quality))
    target = get_preset(preset_name).strings[string - 1].frequency_hz * 2 ** (fret / 12)
    f = spectrum_peak(audio[int(0.2 * SR) :], SR, target, 0.08)
    return string, fret, float(cents(f, target)), decay_db_per_s(audio, SR, f)


def tables(preset_name: str, quality: Quality, uncompensated: bool, pool,
           frets: tuple[int, ...] = FRETS) -> tuple[np.ndarray, np.ndarray]:
    """Cents from 12-TET and decay (dB/s) of ``frets`` on every string."""
    n = get_preset(preset_name).n_strings
    jobs = [(preset_name, s, q, quality, uncompensated) for s in range(1, n + 1) for q in frets]
    err = np.zeros((n, len(frets)))
    decay = np.zeros((n, len(frets)))
    for s, q, c, d in pool.map(fretted_note, jobs):
        err[s - 1, frets.index(q)] = c
        decay[s - 1, frets.index(q)] = d
    return err, decay


def table(preset_name: str, quality: Quality, uncompensated: bool, pool,
          frets: tuple[int, ...] = FRETS) -> np.ndarray:
    """Cents from 12-TET of ``frets`` on every string."""
    return tables(preset_name, quality, uncompensated, pool, frets)[0]


def worst(x: np.ndarray) -> float:
    """The entry of ``x`` largest in magnitude, with its sign."""
    return float(x.flat[np.argmax(np.abs(x))])


def print_table(title: str, err: np.ndarray, unit: str = "cents",
                frets: tuple[int, ...] = FRETS) -> None:
    print(f"\n{title}")
    print("string | " + " ".join(f"{q:>6d}" for q in frets) + " |  worst")
    for s, row in enumerate(err, start=1):
        print(f"{s:>6d} | " + " ".join(f"{c:+6.1f}" for c in row) + f" | {worst(row):+6.1f}")
    print(f"all strings: worst {worst(err):+.1f} {unit}")


def print_split(title: str, err: np.ndarray, frets: tuple[int, ...]) -> None:
    """``print_table`` of frets 1-12 and, separately, of the frets above."""
    low = [i for i, q in enumerate(frets) if q <= 12]
    high = [i for i, q in enumerate(frets) if q > 12]
    print_table(f"{title}, frets 1-12", err[:, low], frets=tuple(frets[i] for i in low))
    if high:
        print_table(f"{title}, frets {frets[high[0]]}-{frets[high[-1]]}", err[:, high],
                    frets=tuple(frets[i] for i in high))


def compensation_effect(scale: float, setback: float, nut: float,
                        frets: tuple[int, ...] = FRETS) -> np.ndarray:
    """Cents a saddle setback and a nut compensation add to ``frets`` of an ideal string,
    relative to its open string: the open string speaks over scale + setback - nut, fret q over
    scale 2^(-q/12) + setback."""
    q = np.array(frets, dtype=float)
    ratio = (scale + setback - nut) / (scale * 2.0 ** (-q / 12.0) + setback)
    return 1200.0 * np.log2(ratio) - 100.0 * q


SETBACKS = np.arange(0.0, 20e-3 + 1e-9, 5e-5)  # the fit's search grids (m): 0.05 mm steps
NUTS = np.arange(0.0, MAX_NUT_COMPENSATION_M + 1e-9, 5e-5)


def fit_compensation(err: np.ndarray, scale: float,
                     frets: tuple[int, ...]) -> list[tuple[float, float]]:
    """Per string (row of ``err``, cents at ``frets`` with no compensation): the (setback, nut
    compensation) on the search grids that minimises the largest |error| over ``frets``."""
    effect = np.array([[compensation_effect(scale, d, c, frets) for c in NUTS] for d in SETBACKS])
    best = []
    for row in err:
        worst = np.max(np.abs(row + effect), axis=2)
        i, j = np.unravel_index(int(np.argmin(worst)), worst.shape)
        best.append((float(SETBACKS[i]), float(NUTS[j])))
    return best


def above_12th(preset_name: str, quality_name: str, pool) -> None:
    """Frets 13 up to the last with the preset's compensation at one quality: what a score that
    climbs the neck gets."""
    preset = get_preset(preset_name)
    frets = tuple(range(13, preset.frets + 1))
    err = table(preset_name, QUALITY[quality_name], False, pool, frets)
    print_table(f"{preset_name}, quality '{quality_name}', frets 13-{preset.frets} with the "
                "preset's compensation (cents from 12-TET)", err, frets=frets)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--preset", default="steel-acoustic", choices=sorted(PRESETS))
    ap.add_argument("--fit-only", action="store_true")
    ap.add_argument("--above-12th", metavar="QUALITY", choices=sorted(QUALITY),
                    help="only frets 13 and up at this quality, with the preset's compensation")
    args = ap.parse_args()
    if args.above_12th:
        with Pool(2) as pool:
            above_12th(args.preset, args.above_12th, pool)
        return
    preset = get_preset(args.preset)
    every = tuple(range(1, preset.frets + 1))
    t0 = time.perf_counter()
    with Pool(2) as pool:
        raw = table(args.preset, REFERENCE, True, pool, every)
        print_split(f"{args.preset}: no compensation, reference grid h <= 1.5 mm, finger "
                    f"{preset.finger.press_force_n:g} N or more (intonation.press_force) "
                    "(cents from 12-TET)", raw, every)
        fit = fit_compensation(raw, preset.scale_length_m, every)
        print(f"\nsaddle setback and nut compensation that minimise the worst error over frets "
              f"1-{preset.frets} (mm):")
        for s, (d, c) in enumerate(fit, start=1):
            print(f"  string {s}: setback {d * 1e3:.2f}, nut {c * 1e3:.2f}")
        predicted = raw + np.array([compensation_effect(preset.scale_length_m, d, c, every)
                                    for d, c in fit])
        print_split("predicted with those (reference grid)", predicted, every)
        if not args.fit_only:
            print("\npreset's setbacks (mm): "
                  + ", ".join(f"{s.saddle_setback_m * 1e3:.2f}" for s in preset.strings)
                  + "; nut compensation (mm): "
                  + ", ".join(f"{s.nut_compensation_m * 1e3:.2f}" for s in preset.strings))
            for name, q in QUALITY.items():
                print_split(f"quality '{name}' with the preset's compensation",
                            table(args.preset, q, False, pool, every), every)
            print_split("reference grid with the preset's compensation",
                        table(args.preset, REFERENCE, False, pool, every), every)
    print(f"\n({time.perf_counter() - t0:.0f} s on this machine)")


if __name__ == "__main__":
    main()
