"""Why a coarse grid puts fretted notes out of tune and shortens them, and the calibration that
takes both errors out.

``engine.fd.intonation`` models a held note as a linear system on the string's grid (the scheme's
stiffness and mass, the frets on both sides of the finger as constraints, the finger as a damped
mass on its contact spring) and calibrates the stopped frets' interpolants with it.  This script
checks the model and the calibration against rendered notes (``benchmarks.intonation``'s scene)
for every string and frets 1-12 on the grids of one quality level, and prints what calibrating
those frets costs (once, in one process):

1. the grid's share of the error, frets left where they are: the rendered pitch on the quality's
   grid minus that on the reference grid (h <= 1.5 mm), and the model's same difference;
2. with the stopped frets calibrated, their fingers moved with them and the fingers' damping
   calibrated (what `draft` and `standard` render): the rendered pitch minus the reference
   grid's, which the calibration aims to make zero;
3. the decay of the fundamental (dB/s; rendered: a line fitted over 0.2-1.15 s; the model: its
   mode's decay by the finger's contact damping) minus the reference grid's, frets where they are
   (rendered and the model), frets calibrated for pitch alone, and frets and fingers' damping
   calibrated (rendered).  The same sub-grid geometry sets how much of the sounding string
   reaches the finger's damping: on a coarse grid a fretted note dies faster, which the finger's
   damping calibrated per fret (``intonation.finger_damping``) takes out;
4. the calibrated damping of each fret's finger (N s/m; the preset's is 8).

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
from engine import calibration_store, config
from engine.fd.intonation import fret_calibration, fret_calibrations, fret_shift, held_note
from engine.fd.voice import oversample_for
from engine.options import QUALITY, Quality
from engine.presets import PRESETS, Preset, get_preset


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
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--preset", default="steel-acoustic", choices=sorted(PRESETS))
    ap.add_argument("--quality", default="draft", choices=list(QUALITY))
    args = ap.parse_args(argv)
    preset = get_preset(args.preset)
    quality = QUALITY[args.quality]
    t0 = time.perf_counter()
    model, model_decay = predicted(preset, quality)
    fret_shift.cache_clear()
    fret_calibration.cache_clear()
    # the calibrations computed, neither read from the store on disk nor written to it
    store_on, config.CALIBRATION_CACHE = config.CALIBRATION_CACHE, False
    calibration_store.reset()
    try:
        t1 = time.perf_counter()
        dampings = np.zeros((preset.n_strings, len(FRETS)))
        for i, spec in enumerate(preset.strings, start=1):
            cal = fret_calibrations(oversample_for(spec, preset.string_length_m(i), SR,
                                                   quality)[1], preset, FRETS)
            dampings[i - 1] = [cal[q].damping_n_s_m for q in FRETS]
        calibration = time.perf_counter() - t1
    finally:
        config.CALIBRATION_CACHE = store_on
        calibration_store.reset()
    raw = replace(quality, calibrate_frets=False)
    pitch_only = replace(quality, calibrate_frets=True, calibrate_damping=False)
    calibrated = replace(quality, calibrate_frets=True, calibrate_damping=True)
    with Pool(2) as pool:
        reference, ref_decay = tables(args.preset, REFERENCE, False, pool)
        raw_cents, raw_decay = tables(args.preset, raw, False, pool)
        _, pitch_decay = tables(args.preset, pitch_only, False, pool)
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
    print_table("3. frets calibrated for pitch alone, rendered notes: quality minus reference",
                pitch_decay - ref_decay, "dB/s")
    print_table("3. frets and fingers' damping calibrated, rendered notes: quality minus reference",
                cal_decay - ref_decay, "dB/s")
    worst = [np.max(np.abs(d)) for d in (decay, pitch_decay - ref_decay, cal_decay - ref_decay)]
    print(f"worst |decay error| over the {ref_decay.size} notes: frets where they are "
          f"{worst[0]:.1f}, calibrated for pitch {worst[1]:.1f}, pitch and damping {worst[2]:.1f} "
          f"dB/s; worst |pitch error| calibrated {np.max(np.abs(after)):.2f} cents")
    print_table("4. the calibrated finger's damping (N s/m)", dampings, "N s/m")
    n = preset.n_strings * len(FRETS)
    print(f"\ncalibrating the {n} frets (engine.fd.intonation.fret_calibrations, one process, "
          f"computed, the store on disk off): {calibration:.1f} s, "
          f"{calibration / n * 1e3:.0f} ms per fret")
    print(f"\n({time.perf_counter() - t0:.0f} s on this machine)")


if __name__ == "__main__":
    main()
