"""How a damped string dies away in both models: the level of its pickup signal in windows after
a ``damp``, the strongest partials of each window, and when it falls silent.

    python -m tools.damped_tail [--strings 1,3,6] [--damp 0.3] [--force 2.0]

Each open string of the steel-string preset is plucked at 0 s and damped at ``--damp`` s
(``engine.performance.DAMP_*``: four fingertips behind fret 5, 35 mm apart), no body, 44.1 kHz.
The finite-difference model is the physics reference; the waveguide is rendered with its damped
rest and its decay stop off (``damped_velocity=0``, ``skip_decayed=False``), so that what is
printed is its damped decay itself, not where its rest would cut it.  Per window: the RMS level
(dB re 1 m/s) and the three strongest spectral peaks (Hann window, peaks 30 Hz apart); last, the
time of the last sample above 1e-7 m/s (the decay stop's bound) in a render with both on, as the
songs are rendered.
"""

from __future__ import annotations

import argparse

import numpy as np

from engine.mix import prepare
from engine.scene import parse_scene

RATE = 44100
WINDOWS = ((0.02, 0.06), (0.06, 0.10), (0.10, 0.15), (0.15, 0.25))  # after the damp, s


def render(model: str, string: int, damp: float, force: float, exact: bool) -> np.ndarray:
    sc = parse_scene({"duration": damp + 0.9, "model": model, "sample_rate": RATE,
                      "output": {"normalize": False, "body": "none"},
                      "events": [{"type": "pluck", "time": 0.0, "string": string, "force": force},
                                 {"type": "damp", "time": damp, "string": string}]})
    mix = prepare(sc)
    if exact and model == "waveguide":
        for v in mix.voices:
            v.set_switches(damped_velocity=0.0, skip_decayed=False)
    return np.concatenate(list(mix.blocks(4096)))


def peaks(seg: np.ndarray, count: int = 3) -> list[float]:
    spectrum = np.abs(np.fft.rfft(seg * np.hanning(len(seg)), 1 << 16))
    freqs = np.fft.rfftfreq(1 << 16, 1.0 / RATE)
    found: list[float] = []
    for i in np.argsort(spectrum)[::-1]:
        if all(abs(freqs[i] - f) > 30.0 for f in found):
            found.append(float(freqs[i]))
        if len(found) == count:
            break
    return found


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--strings", default="1,3,6", help="open strings to pluck (1 = high E)")
    ap.add_argument("--damp", type=float, default=0.3, help="time of the damp, s")
    ap.add_argument("--force", type=float, default=2.0, help="pluck force, N")
    args = ap.parse_args()
    heads = " | ".join(f"+{a * 1000:.0f}-{b * 1000:.0f} ms" for a, b in WINDOWS)
    print(f"| string | model | {heads} | last above 1e-7 m/s |")
    print("| --- | --- |" + " --- |" * (len(WINDOWS) + 1))
    for string in (int(s) for s in args.strings.split(",")):
        for model in ("fdtd", "waveguide"):
            y = render(model, string, args.damp, args.force, exact=True)
            cells = []
            for a, b in WINDOWS:
                seg = y[int((args.damp + a) * RATE):int((args.damp + b) * RATE)]
                level = 20.0 * np.log10(np.sqrt(np.mean(seg * seg)) + 1e-300)
                top = ", ".join(f"{f:.0f}" for f in peaks(seg))
                cells.append(f"{level:.1f} dB ({top} Hz)" if level > -250.0 else "silent")
            loud = np.nonzero(np.abs(render(model, string, args.damp, args.force, False)) > 1e-7)[0]
            last = f"{loud[-1] / RATE - args.damp:+.3f} s" if len(loud) else "never"
            print(f"| {string} | {model} | " + " | ".join(cells) + f" | {last} |", flush=True)


if __name__ == "__main__":
    main()
