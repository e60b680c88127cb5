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

    python -m tools.damped_tail --nodes [--strings 6]

Where the waveguide's lingering partial stands on the string: the waveguide string's state
``NODES_AT`` s after the damp (decay stop and damped rest off), its displacement along the grid
over ``NODES_STEPS`` samples demodulated at the pickup's strongest partial then: that partial's
amplitude profile.  Printed: where the grid begins (``voice.x_of(0)``: the
grid is laid from the bridge at the nominal wave speed, and the termination's filters stand for
the rest of the string), the strongest partial of the pickup signal then and its number k on the
open string, and per fingertip the profile's amplitude there against its largest, beside the
distance to the nearest node of the physical string's k-th partial (j L / k from the nut) and to
the nearest node of the waveguide's profile.
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


NODES_AT = 0.2  # s after the damp
NODES_STEPS = 256  # samples of the profile: some nine periods of a partial near 1.5 kHz


def nodes(string: int, damp: float, force: float) -> None:
    """The ``--nodes`` table for one open string (the module's docstring)."""
    sc = parse_scene({"duration": damp + NODES_AT + 0.05, "model": "waveguide",
                      "sample_rate": RATE, "output": {"normalize": False, "body": "none"},
                      "events": [{"type": "pluck", "time": 0.0, "string": string, "force": force},
                                 {"type": "damp", "time": damp, "string": string}]})
    v = prepare(sc).voices[0]
    v.set_switches(damped_velocity=0.0, skip_decayed=False)
    y = v.run(int((damp + NODES_AT) * RATE))
    f = peaks(y[-int(0.1 * RATE):], 1)[0]
    partials = v.partial_frequencies(64)
    if f < 0.5 * partials[0]:
        print(f"string {string}: the pickup's strongest component {NODES_AT * 1000:.0f} ms after "
              f"the damp is at {f:.0f} Hz, below the string's first partial ({partials[0]:.0f} "
              "Hz): the creep to the rest line, no partial lingers")
        return
    k = int(np.argmin(np.abs(partials - f))) + 1
    R, Mb = v.rails
    mask = R.shape[0] - 1
    nt = int(v.carry[0]["n_t"])
    grid = np.arange(nt, v.n + 1)
    u = []
    for _ in range(NODES_STEPS):
        v.run(1)
        u.append(R[(v.step - grid) & mask] + Mb[(v.step + grid) & mask])
    # the partial's amplitude at each point: the displacement demodulated at its frequency
    # (Hann-windowed, so neither the creep nor the other partials leak in)
    u = np.array(u)
    w = np.hanning(NODES_STEPS) * np.exp(-2j * np.pi * f / RATE * np.arange(NODES_STEPS))
    profile = np.abs(w @ u)
    x = v.x_of(grid)
    # the profile's nodes: its local minima below a quarter of its largest value
    inner = np.arange(1, len(profile) - 1)
    low = inner[(profile[inner] <= profile[inner - 1]) & (profile[inner] <= profile[inner + 1])
                & (profile[inner] < 0.25 * profile.max())]
    length = v.phys.length_m
    print(f"string {string}: the grid begins {1000 * v.x_of(0):.1f} mm from the nut; the pickup's "
          f"strongest partial {NODES_AT * 1000:.0f} ms after the damp: {f:.0f} Hz, partial {k} "
          f"({partials[k - 1]:.0f} Hz); nodes of the physical string's partial {k}: "
          f"{1000 * length / k:.1f} mm apart, of the waveguide's profile: "
          + (f"{1000 * float(np.median(np.diff(x[low]))):.1f} mm apart" if len(low) > 1 else "-"))
    print("| fingertip, mm from the nut | amplitude there / largest | to the physical node, mm "
          "| to the waveguide's node, mm |")
    print("| ---: | ---: | ---: | ---: |")
    for sl in v.timeline.slots:
        if sl.window != "split" or sl.length != 0 or sl.on < int(damp * RATE):
            continue
        xm = sl.x_m
        amp = float(np.interp(xm, x, profile)) / float(profile.max())
        physical = min(abs(xm - j * length / k) for j in range(k + 1))
        ours = float(np.min(np.abs(x[low] - xm))) if len(low) else float("nan")
        print(f"| {1000 * xm:.1f} | {amp:.3f} | {1000 * physical:.1f} | {1000 * ours:.1f} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--strings", default="1,3,6", help="open strings to pluck (1 = high E)")
    ap.add_argument("--damp", type=float, default=0.3, help="time of the damp, s")
    ap.add_argument("--force", type=float, default=2.0, help="pluck force, N")
    ap.add_argument("--nodes", action="store_true",
                    help="where the waveguide's lingering partial has its nodes (the docstring)")
    args = ap.parse_args()
    if args.nodes:
        for string in (int(s) for s in args.strings.split(",")):
            nodes(string, args.damp, args.force)
        return
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
