"""Where a waveguide render of a whole song spends its CPU: the kernel, the Python around its calls,
the mixing, by the kernel's paths.

    python -m tools.wg_song_profile FILE [FILE ...] [--max-seconds S] [--damped-velocity V]

Each FILE becomes the scene ``guitar-synth render FILE --model waveguide --all-instruments
[--max-seconds S]`` renders (``benchmarks.songs``' command), rendered in one process on one thread
as the CLI does (``engine.mix``, in the CLI's blocks: ``cli.main.BLOCK_FRAMES``, 16384 frames; the
samples do not depend on the blocks, the number of kernel calls does), after a half second of the
same scene has loaded the compiled kernels.  Printed per song (process CPU time for the phases,
``perf_counter`` around the calls for the split of the render):

* ``load``, ``prepare``, ``render``: reading the score, preparing the strings, rendering;
* ``kernel``: inside the waveguide kernel's calls; ``python``: the rest of the voices' ``run``
  (events, stops, sleeping, waking, building the calls); ``mix``: the rest of the render (pan,
  bodies, effects, summing);
* the kernel's calls, by how many steps they asked for, with their share of the kernel's time;
  and its calls with a damper in contact (a damp, palm, touch or light finger whose contact holds
  one of the call's steps) against the rest, with the collision points live at their start;
* the string-steps: in the general step, in plain runs and asleep (the kernel's and the voice's
  counts), of all the strings' steps (strings with no events are not built);
* ``sha256``: of the mixed output, so that two trees' renders can be compared.

``--damped-velocity V`` renders with ``WaveguideOptions.damped_velocity`` = V m/s (the damped rest's
bound on the points of a damped string, ``kernel._settle``; 0: no damped rest, the creep runs to
the string's next note).

The timing around every kernel call costs time of its own (a few array reads a call), measured and
left out of ``python``; the render's CPU time includes it.
"""

from __future__ import annotations

import argparse
import hashlib
import sys
import time

import numpy as np

from engine.waveguide import WaveguideOptions
from tools.song_scene import song_scene


def profile(path: str, seconds: float | None, damped_velocity: float | None = None) -> str:
    import engine
    import engine.waveguide.voice as wv
    from cli.main import BLOCK_FRAMES
    from engine.mix import prepare

    calls: list[tuple] = []
    clock = time.perf_counter
    entry = wv.entry_point
    run = wv.WaveguideVoice.run
    spent = [0.0]
    over = [0.0]

    def counting(dispatcher, args):
        fn = entry(dispatcher, args)

        def call(*a):
            t_in = clock()
            sl, s0, m = a[1].slots, a[2], a[3].shape[0]
            nlive = int(a[0].carry[0]["nlive"])
            t0 = clock()
            n = fn(*a)
            dt = clock() - t0
            held = (sl["on"] < s0 + m) & (sl["off"] + sl["rel"] > s0) & (sl["length"] == 0)
            calls.append((m, max(n, 0), dt, bool(held.any()), nlive))
            over[0] += clock() - t_in - dt  # this wrapper's own time, left out of ``python``
            return n
        return call

    def timed_run(self, nsteps):
        t0 = clock()
        y = run(self, nsteps)
        spent[0] += clock() - t0
        return y

    wv.entry_point = counting
    wv.WaveguideVoice.run = timed_run
    try:
        for _ in engine.blocks(song_scene(path, 0.5)):  # load the kernels: not counted
            pass
        calls.clear()
        spent[0] = 0.0
        over[0] = 0.0
        t0 = time.process_time()
        sc = song_scene(path, seconds)
        t_load = time.process_time() - t0
        t0 = time.process_time()
        mix = prepare(sc)
        if damped_velocity is not None:
            for v in mix.voices:
                if hasattr(v, "set_switches"):
                    v.set_switches(damped_velocity=damped_velocity)
        t_prep = time.process_time() - t0
        digest = hashlib.sha256()
        t0 = time.process_time()
        w0 = clock()
        for y in mix.blocks(BLOCK_FRAMES):
            digest.update(np.ascontiguousarray(y, np.float64).tobytes())
        t_render = time.process_time() - t0
        w_render = clock() - w0
    finally:
        wv.entry_point = entry
        wv.WaveguideVoice.run = run
    c = np.array(calls, float).reshape(-1, 5)
    kernel = float(c[:, 2].sum())
    wg = [v for v in mix.voices if hasattr(v, "steps_slept")]
    every = max(len(wg) * mix.frames, 1)
    general = sum(int(v.st["general"]) for v in wg)
    plain = sum(int(v.st["plain"]) for v in wg)
    slept = sum(v.steps_slept for v in wg)
    dur = mix.frames / sc.sample_rate
    lines = [f"{path.rsplit('/', 1)[-1]}: {dur:.1f} s, {len(mix.tracks)} tracks, {len(wg)} strings "
             f"built; sha256 {digest.hexdigest()[:16]}",
             f"  CPU s: load {t_load:.2f}, prepare {t_prep:.2f}, render {t_render:.2f} "
             f"({1e3 * t_render / max(len(wg) * dur, 1e-9):.2f} ms per string-second); of the "
             f"render's wall {w_render:.2f} s: kernel {kernel:.2f}, "
             f"python {spent[0] - kernel - over[0]:.2f}, "
             f"mix {w_render - spent[0]:.2f} (the timing's own {over[0]:.2f} left out)",
             f"  string-steps: general {general / every:.1%}, plain {plain / every:.1%}, asleep "
             f"{slept / every:.1%}, stopped or unbuilt {1 - (general + plain + slept) / every:.1%}; "
             f"kernel {1e9 * kernel / max(general + plain, 1):.0f} ns per step run"]
    for lo, hi in ((1, 2), (2, 1024), (1024, 1 << 30)):
        sel = (c[:, 0] >= lo) & (c[:, 0] < hi)
        if sel.any():
            lines.append(f"  calls of {lo}-{min(hi, BLOCK_FRAMES + 1) - 1} steps: {int(sel.sum())}, "
                         f"{c[sel, 2].sum():.2f} s, {1e6 * c[sel, 2].mean():.1f} us a call, "
                         f"{1e9 * c[sel, 2].sum() / max(c[sel, 1].sum(), 1):.0f} ns a step")
    for name, sel in (("a damper in contact", c[:, 3] == 1), ("no damper", c[:, 3] == 0)):
        if sel.any():
            lines.append(f"  calls with {name}: {c[sel, 1].sum() / every:.1%} of the string-steps, "
                         f"{c[sel, 2].sum():.2f} s, "
                         f"{1e9 * c[sel, 2].sum() / max(c[sel, 1].sum(), 1):.0f} ns a step, "
                         f"{c[sel, 4].mean():.1f} collision points live at their start")
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("files", nargs="+", metavar="FILE")
    ap.add_argument("--max-seconds", type=float, metavar="S", help="each song's first S seconds")
    ap.add_argument("--damped-velocity", type=float, default=None, metavar="V",
                    help="WaveguideOptions.damped_velocity, m/s (default: the option's, "
                         f"{WaveguideOptions.damped_velocity:g}; 0: no damped rest)")
    args = ap.parse_args()
    from cli.common import BadInput

    for f in args.files:
        try:
            print(profile(f, args.max_seconds, args.damped_velocity), flush=True)
        except BadInput as e:  # a missing or unreadable file: the CLI's one line, not a traceback
            sys.exit(f"wg_song_profile: {e}")


if __name__ == "__main__":
    main()
