"""How hard a finger must press to hold a fretted note: the static model against rendered notes.

``engine.fd.intonation.seating_force`` solves the statics of the pressed string (the finger pushing
down behind the fret, the string resting on the fret and, where it reaches it, on the fret behind):
the force below which the string cannot rest on its fret.  A finger whose event gives no force
presses with the preset's force or ``SEAT_MARGIN`` times that, whichever is more
(``intonation.press_force``).

For each string and a few frets this script finds, by bisection on the pressing force, the least
force at which a rendered note holds (``benchmarks.intonation``'s scene: the finger, then a pluck
at 0.8 L), and prints it next to the static force.  A note "holds" when the string rests on its
fret: the fret's rigid constraint is in the kernel's active set (``State.fret_active``) at no fewer
than 95 % of the checks, one every 64 output samples from 0.2 s to 1 s.  (A criterion on the audio
was tried first and is not reliable: a lightly touched, unseated string can ring near the note's
pitch, and a seated one's fundamental moves by tens of dB with the force.)  The bisection runs
between 0.5 and 2 times the static force, to 0.02 N.

    python -m benchmarks.seating [--preset steel-acoustic] [--quality standard]
"""

from __future__ import annotations

import argparse
import time
from multiprocessing import Pool

import numpy as np

from engine.fd.intonation import SEAT_MARGIN, press_force, seating_force
from engine.fd.voice import string_model
from engine.options import QUALITY, RenderOptions
from engine.performance import events_on
from engine.presets import get_preset
from engine.testing.measure import holds, seating_scene

SR = 44100
PLUCKS_N = (1.0, 4.0)
RESOLUTION_N = 0.02


def threshold(args) -> tuple[int, int, float, float, list[float]]:
    """(string, fret, static force, default force, rendered threshold per pluck force; -lo if
    the note holds already at the bottom of the bracket, inf if not at its top)."""
    preset_name, quality, string, fret = args
    preset = get_preset(preset_name)
    scene = seating_scene(preset_name, string, fret, None, PLUCKS_N[0])
    # the grid ``prepare`` builds for the rendered notes
    _, model, _ = string_model(preset, string, events_on(scene, preset.n_strings, string), SR,
                               QUALITY[quality], RenderOptions())
    static = seating_force(model, preset, fret)
    default = press_force(model, preset, fret)
    found = []
    for pluck in PLUCKS_N:
        lo, hi = 0.5 * static, 2.0 * static
        if holds(preset_name, quality, string, fret, lo, pluck):
            found.append(-lo)
            continue
        if not holds(preset_name, quality, string, fret, hi, pluck):
            found.append(float("inf"))
            continue
        while hi - lo > RESOLUTION_N:
            mid = 0.5 * (lo + hi)
            if holds(preset_name, quality, string, fret, mid, pluck):
                hi = mid
            else:
                lo = mid
        found.append(hi)
    return string, fret, static, default, found


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--preset", default="steel-acoustic")
    ap.add_argument("--quality", default="standard", choices=list(QUALITY))
    args = ap.parse_args(argv)
    t0 = time.perf_counter()
    preset = get_preset(args.preset)
    frets = sorted({1, 2, 3, 5, 12, 17, preset.frets})
    jobs = [(args.preset, args.quality, s, q) for s in range(1, preset.n_strings + 1)
            for q in frets]
    with Pool(2) as pool:
        rows = pool.map(threshold, jobs)
    print(f"{args.preset}, quality '{args.quality}': pressing force (N) that holds a fretted "
          f"note; preset's force {preset.finger.press_force_n:g} N, SEAT_MARGIN {SEAT_MARGIN:g}")
    head = ("string | fret | static | default | " +
            " | ".join(f"held, {p:g} N pluck | / static" for p in PLUCKS_N))
    print(head)
    ratios: list[list[float]] = [[] for _ in PLUCKS_N]
    bottom = False
    for string, fret, static, default, found in rows:
        cells = []
        for i, f in enumerate(found):
            if f < 0.0:
                bottom = True
                cells.append(f"{'<= ' + format(-f, '.2f') + ' *':>18} | {'-':>8}")
                continue
            ratios[i].append(f / static)
            cells.append(f"{f:18.2f} | {f / static:8.2f}")
        print(f"{string:6d} | {fret:4d} | {static:6.2f} | {default:7.2f} | " + " | ".join(cells))
    if bottom:
        print("* the string rests on its fret already at half the static force: the static model "
              "does not explain this cell; left out of the ratios below")
    for p, r in zip(PLUCKS_N, ratios, strict=True):
        print(f"{p:g} N pluck: the rendered note holds from at most {max(r):.2f} times the static "
              f"force (median {np.median(r):.2f})")
    print(f"\n({time.perf_counter() - t0:.0f} s on this machine)")


if __name__ == "__main__":
    main()
