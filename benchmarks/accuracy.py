"""Physics checks as tables: energy balance, open-string partials, pitch glide.

    python -m benchmarks.accuracy [--quality standard]

1. Relative energy-balance deviation (paper sec. 6.1, normalised by the largest stored energy)
   on scenes that exercise each nonlinearity.
2. Open strings: fundamental against nominal, and the worst of partials 1-10 against the continuous
   stiff string f_n = n f0 sqrt(1 + B n^2) (cents), per string of every preset.
3. Pitch glide of the Kirchhoff-Carrier tension modulation: fundamental in 0.01-0.11 s against
   0.5-0.6 s (cents) for soft to hard plucks.
4. How deep a 10 N tap drives string 1 into the fretboard, checked at every internal step, per
   gradient-correction rule (sec. 4.7) and oversampling factor (um); the static depth of the whole
   force on one grid cell, (F / (K_B h))^(1/alpha), for scale.
"""

from __future__ import annotations

import argparse

import numpy as np

import engine
from engine.analysis import cents, partials, spectrum_peak
from engine.fd.instrument import prepare
from engine.presets import PRESETS
from engine.scene import Scene
from engine.testing.measure import board_depth
from engine.testing.scenes import SR

ENERGY_SCENES = {
    "fret + 8 N pluck + tap (every nonlinearity)": [
        {"type": "fret", "time": 0.0, "string": 2, "fret": 5},
        {"type": "pluck", "time": 0.05, "string": 2, "force": 8.0},
        {"type": "tap", "time": 0.3, "string": 3, "fret": 7, "force": 0.9},
        {"type": "pluck", "time": 0.1, "string": 6, "force": 8.0, "position": 0.9},
    ],
    "finger drop of paper Fig. 2 (0.7 m/s, unforced)": [
        {"type": "tap", "time": 0.0, "string": 4, "fret": 5, "force": 1e-6, "velocity": 0.7},
    ],
    "20 N plucks, 10 N fingers, 5 m/s taps": [
        e for s in range(1, 7) for e in (
            {"type": "fret", "time": 0.0, "string": s, "fret": 1 + 2 * s, "force": 10.0},
            {"type": "pluck", "time": 0.01, "string": s, "force": 20.0, "duration": 1e-4},
            {"type": "tap", "time": 0.05, "string": s, "fret": 12, "force": 10.0,
             "velocity": 5.0})
    ],
}


def energy(quality: str) -> None:
    print(f"\nenergy balance, quality '{quality}' (max relative deviation per step)")
    for name, evs in ENERGY_SCENES.items():
        r = engine.render({"duration": 0.5, "events": evs, "quality": quality,
                           "output": {"body": "none"}}, diagnostics=True)
        print(f"  {name:48s} {r.energy_error:9.2e}")


def open_strings(quality: str) -> None:
    print(f"\nopen strings, 0.2 N pluck, quality '{quality}' (cents)")
    print("preset          string | fundamental vs nominal | worst of partials 1-10 vs f_n")
    for preset in sorted(PRESETS):
        for s in range(1, PRESETS[preset].n_strings + 1):
            sc = Scene.model_validate({"duration": 2.0, "quality": quality,
                                       "guitar": {"preset": preset},
                                       "output": {"body": "none", "pickup_position": 0.913},
                                       "events": [{"type": "pluck", "time": 0.0, "string": s,
                                                   "force": 0.2, "position": 0.83}]})
            m = prepare(sc).voices[0].model
            x = engine.render(sc)[int(0.05 * SR):]
            f1 = spectrum_peak(x, SR, m.spec.frequency_hz)
            n = np.arange(1, 11)
            expected = np.array([m.target_frequency(i) for i in n])
            worst = np.max(np.abs(cents(partials(x, SR, m.spec.frequency_hz, 10,
                                                m.inharmonicity()), expected)))
            print(f"{preset:15s} {s:6d} | {cents(f1, m.spec.frequency_hz):+22.3f} | {worst:29.3f}")


def glide(quality: str) -> None:
    print(f"\npitch glide (fundamental 0.01-0.11 s minus 0.5-0.6 s, cents), quality '{quality}'")
    forces = (0.2, 2.0, 8.0, 20.0)
    print("string | " + " | ".join(f"{f:5.1f} N" for f in forces))
    for s in range(1, PRESETS["steel-acoustic"].n_strings + 1):  # the scenes' default preset
        row = []
        f0 = PRESETS["steel-acoustic"].strings[s - 1].frequency_hz
        for force in forces:
            a = engine.render({"duration": 0.7, "quality": quality, "output": {"body": "none"},
                               "events": [
                {"type": "pluck", "time": 0.0, "string": s, "force": force}]})
            early = spectrum_peak(a[int(0.01 * SR):int(0.11 * SR)], SR, f0, 0.05)
            late = spectrum_peak(a[int(0.5 * SR):int(0.6 * SR)], SR, f0, 0.05)
            row.append(float(cents(early, late)))
        print(f"{s:6d} | " + " | ".join(f"{c:+7.2f}" for c in row))


def board_sink() -> None:
    print("\ndepth below the fretboard of a 10 N tap at fret 12, string 1, every internal step (um)")
    print("tap speed | x | static depth | joint (engine) | per column | eq. (61) | gamma = 1")
    for vel in (1.0, 5.0):
        for os_ in (2, 4, 8):
            cells = []
            for rule, width in (("joint", 14), ("own", 10), ("paper", 8), ("none", 9)):
                depth, static = board_depth(vel, os_, rule)
                cells.append(f"{depth * 1e6:{width}.0f}")
            print(f"{vel:5.0f} m/s | {os_} | {static * 1e6:12.0f} | {' | '.join(cells)}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quality", default="standard", choices=["draft", "standard", "high"])
    args = ap.parse_args()
    energy(args.quality)
    open_strings(args.quality)
    glide(args.quality)
    board_sink()


if __name__ == "__main__":
    main()
