"""How hard a finger must press to hold a fretted note: the static model against rendered notes.

``engine.intonation.seating_force`` solves the statics of the pressed string (the finger pushing
down behind the fret, the string resting on the fret behind it and on the fret): the force below
which the string cannot rest on its fret.  A finger whose event gives no force presses with the
preset's force or ``SEAT_MARGIN`` times that, whichever is more (``intonation.press_force``).

For each string and a few frets this script finds, by bisection on the pressing force, the least
force at which a rendered note holds (``benchmarks.intonation``'s scene: the finger, then a pluck
at 0.8 L), and prints it next to the static force.  A note "holds" when its fundamental is within
10 cents of the same note pressed with twice the default force and no more than 30 dB weaker
(an unseated string sounds another pitch or leaves the note far weaker; seated, the note's level
still moves with the force, most near the threshold, where it buzzes).  The bisection runs
between 0.5 and 2 times the static force, to 0.02 N.

    python -m benchmarks.seating [--preset steel-acoustic] [--quality standard]
"""

from __future__ import annotations

import argparse
import time
from multiprocessing import Pool

import numpy as np

import engine
from engine.analysis import cents, spectrum_peak
from engine.guitar import QUALITY, RenderOptions, oversample_for
from engine.intonation import SEAT_MARGIN, press_force, seating_force
from engine.presets import get_preset

SR = 44100
PLUCKS_N = (1.0, 4.0)
RESOLUTION_N = 0.02


def note(preset_name: str, quality: str, string: int, fret: int, force: float,
         pluck: float) -> tuple[float, float]:
    """Frequency (Hz) of the strongest component within 0.08 of the fretted note's fundamental,
    from 0.2 s, and its level (dB)."""
    scene = {"duration": 1.0, "sample_rate": SR, "guitar": {"preset": preset_name},
             "output": {"body": "none", "channels": 1, "normalize": False},
             "events": [{"type": "fret", "time": 0.0, "string": string, "fret": fret,
                         "force": force},
                        {"type": "pluck", "time": 0.05, "string": string, "force": pluck}]}
    audio = engine.render(scene, options=RenderOptions(quality=QUALITY[quality]))
    target = get_preset(preset_name).strings[string - 1].frequency_hz * 2 ** (fret / 12)
    tail = audio[int(0.2 * SR):]
    f = spectrum_peak(tail, SR, target, 0.08)
    tone = np.exp(-2j * np.pi * f * np.arange(tail.size) / SR)
    level = 20.0 * np.log10(abs(np.sum(tail * np.hanning(tail.size) * tone)) + 1e-300)
    return f, level


def threshold(args) -> tuple[int, int, float, float, list[float]]:
    """(string, fret, static force, default force, rendered threshold per pluck force)."""
    preset_name, quality, string, fret = args
    preset = get_preset(preset_name)
    spec = preset.strings[string - 1]
    _, model = oversample_for(spec, preset.string_length_m(string), SR, QUALITY[quality])
    static = seating_force(model, preset, fret)
    default = press_force(model, preset, fret)
    found = []
    for pluck in PLUCKS_N:
        f_ref, l_ref = note(preset_name, quality, string, fret, 2.0 * default, pluck)

        def holds(force: float, pluck=pluck, f_ref=f_ref, l_ref=l_ref) -> bool:
            f, level = note(preset_name, quality, string, fret, force, pluck)
            return abs(float(cents(f, f_ref))) <= 10.0 and level >= l_ref - 30.0

        lo, hi = 0.5 * static, 2.0 * static
        if holds(lo):  # already at the bottom of the bracket (see the footnote in ``main``)
            found.append(-lo)
            continue
        if not holds(hi):
            found.append(float("inf"))
            continue
        while hi - lo > RESOLUTION_N:
            mid = 0.5 * (lo + hi)
            if holds(mid):
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
    frets = sorted({1, 5, 12, 17, preset.frets})
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
        print("* the criterion is met already at half the static force, where the string cannot "
              "rest on the fret, so the cell\n  says nothing about the threshold (at fret 12 the "
              "unseated string's second partial has the note's pitch:\n  the finger touches it "
              "where the harmonic is played); left out of the ratios below")
    for p, r in zip(PLUCKS_N, ratios, strict=True):
        print(f"{p:g} N pluck: the rendered note holds from at most {max(r):.2f} times the static "
              f"force (median {np.median(r):.2f})")
    print(f"\n({time.perf_counter() - t0:.0f} s on this machine)")


if __name__ == "__main__":
    main()
