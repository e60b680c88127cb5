"""Why a coarse grid puts fretted notes out of tune and shortens them, and the calibration that
takes the pitch error out.

``engine.intonation`` models a held note as a linear system on the string's grid (the scheme's
stiffness and mass, the frets on both sides of the finger as constraints, the finger as a damped
mass on its contact spring) and calibrates the stopped frets' interpolants with it.  This script
checks the model and the calibration against rendered notes (``benchmarks.intonation``'s scene)
for every string and frets 1-12 on the grids of one quality level, and prints what calibrating
those frets costs (once, in one process):

1. the grid's share of the error, frets left where they are: the rendered pitch on the quality's
   grid minus that on the reference grid (h <= 1.5 mm), and the model's same difference;
2. with the stopped frets calibrated, their fingers moved with them (what `draft` and `standard`
   render): the rendered pitch minus the reference grid's, which the calibration aims to make
   zero;
3. the decay of the fundamental (dB/s; rendered: a line fitted over 0.2-1.15 s; the model: its
   mode's decay by the finger's contact damping) minus the reference grid's, frets where they are
   (rendered and the model) and calibrated (rendered).  The same sub-grid geometry sets how much
   of the sounding string reaches the finger's damping: on a coarse grid a fretted note dies
   faster.  The calibration does not aim at it.

    python -m benchmarks.fret_modes [--preset steel-acoustic] [--quality draft]
"""

from __future__ import annotations

import argparse
import math
import time
from dataclasses import replace
from multiprocessing import Pool

import numpy as np

from benchmarks.intonation import FRETS, REFERENCE, SR, print_table, tables
from engine.intonation import fret_shift, fret_shifts, held_note
from engine.options import QUALITY, Quality
from engine.presets import Preset, get_preset
from engine.voice import oversample_for


def predicted(preset: Preset, quality: Quality) -> tuple[np.ndarray, np.ndarray]:
    """The model's grid error, frets where they are: the quality's grid against the reference
    grid, in cents and in dB/s of decay."""
    err = np.zeros((preset.n_strings, len(FRETS)))
    decay = np.zeros((preset.n_strings, len(FRETS)))
    for s, spec in enumerate(preset.strings, start=1):
        length = preset.string_length_m(s)
        _, coarse = oversample_for(spec, length, SR, quality)
        _, fine = oversample_for(spec, length, SR, REFERENCE)
        for i, q in enumerate(FRETS):
            target = spec.frequency_hz * 2.0 ** (q / 12.0)
            got = held_note(coarse, preset, q, target)
            want = held_note(fine, preset, q, target)
            err[s - 1, i] = 1200.0 * math.log2(got.frequency_hz / want.frequency_hz)
            decay[s - 1, i] = got.decay_db_s - want.decay_db_s
    return err, decay


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", default="steel-acoustic")
    ap.add_argument("--quality", default="draft", choices=list(QUALITY))
    args = ap.parse_args(argv)
    preset = get_preset(args.preset)
    quality = QUALITY[args.quality]
    t0 = time.perf_counter()
    model, model_decay = predicted(preset, quality)
    fret_shift.cache_clear()
    t1 = time.perf_counter()
    for i, spec in enumerate(preset.strings, start=1):
        fret_shifts(oversample_for(spec, preset.string_length_m(i), SR, quality)[1], preset, FRETS)
    calibration = time.perf_counter() - t1
    raw = replace(quality, calibrate_frets=False)
    calibrated = replace(quality, calibrate_frets=True)
    with Pool(2) as pool:
        reference, ref_decay = tables(args.preset, REFERENCE, False, pool)
        raw_cents, raw_decay = tables(args.preset, raw, False, pool)
        cal_cents, cal_decay = tables(args.preset, calibrated, False, pool)
    rendered = raw_cents - reference
    after = cal_cents - reference
    grid = ", ".join(f"{oversample_for(s, preset.string_length_m(i), SR, quality)[1].h * 1e3:.2f}"
                     for i, s in enumerate(preset.strings, start=1))
    print(f"{args.preset}, quality '{args.quality}' (h in mm by string: {grid}) against the "
          f"reference grid (h <= 1.5 mm), cents, frets 1-12, finger "
          f"{preset.finger.press_force_n:g} N or more (intonation.press_force)")
    print_table("1. frets where they are, rendered notes: quality minus reference", rendered)
    print_table("1. frets where they are, the model: quality minus reference", model)
    print_table("1. model minus rendered", model - rendered)
    print_table("2. frets calibrated, rendered notes: quality minus reference", after)
    decay = raw_decay - ref_decay
    print_table("3. decay of the fundamental (dB/s; negative: dies faster), frets where they are, "
                "rendered notes: quality minus reference", decay, "dB/s")
    print_table("3. frets where they are, the model: quality minus reference", model_decay, "dB/s")
    print_table("3. model minus rendered", model_decay - decay, "dB/s")
    apart = np.abs(model_decay - decay)
    print(f"model and rendered decay within 0.5 dB/s on {int(np.sum(apart <= 0.5))} of "
          f"{apart.size} notes, within 0.1 dB/s on {int(np.sum(apart <= 0.1))}")
    print_table("3. frets calibrated, rendered notes: quality minus reference",
                cal_decay - ref_decay, "dB/s")
    n = preset.n_strings * len(FRETS)
    print(f"\ncalibrating the {n} frets (engine.intonation.fret_shifts, one process, empty cache): "
          f"{calibration:.1f} s, {calibration / n * 1e3:.0f} ms per fret")
    print(f"\n({time.perf_counter() - t0:.0f} s on this machine)")


if __name__ == "__main__":
    main()
