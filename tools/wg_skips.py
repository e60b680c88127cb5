"""What the waveguide's skips change: each render with a skip on against the same render with it off.

    python -m tools.wg_skips [--seconds 20] [--sensitivity] [FILE ...]

Two skips of ``engine/waveguide`` are measured, on whole songs (corpus files nobody on this project
wrote: ``make test-data``) and on ``tools.render_digest``'s waveguide scenes:

* steady runs (``WaveguideOptions.steady_runs``, ``kernel._steady``): steady junctions, a
  damper in contact or a released junction leaking away, stepped in the kernel's plain runs
  instead of its general step.  Exact: not one sample may differ.
* the damper bound (``WaveguideOptions.damper_bound``, ``kernel._reach``): the collision points
  beside a damper in contact (a damp, a palm, a harmonic touch, a light finger) live only where
  the string's energy bound reaches their obstacle, instead of all of them tested every sample
  for the whole contact.  Meant to be exact: the bound is the one the kernel already relies on
  while a released junction's perturbation leaks away, and a point it leaves out cannot reach its
  obstacle before the next bound, so no collision is missed; the column says whether a sample
  moved, and the collision point-steps tested with the bound against without it.
* the decay stop between events (``skip_decayed``, ``kernel._may_sleep``, ``voice._sleep``): a
  string whose every point and pickups move slower than ``decay_velocity`` (1e-7 m/s) with
  nothing to act on it for ``kernel.LOOKAHEAD`` steps sleeps until its next event, its state
  kept, or stops when none is left.  Its tolerance: -140 dB of full scale after the fixed gain
  (``TOLERANCE``: 3.3e-6 m/s of the output before it, 33 x ``decay_velocity``).  A string that
  stops for good drops less than 2 x ``decay_velocity`` (tests/engine/waveguide/
  test_decay_stop.py); one that sleeps resumes its frozen decay at its next note, where a
  collision grazing an obstacle may see the difference (tests/engine/waveguide/test_skips.py:
  a 2 N pluck on a fretted string that slept, 6.5e-7 m/s, -154 dB of full scale).
* the damped rest (``WaveguideOptions.damped_velocity``, ``kernel._settle``): not a skip but a
  rule of the model that lets strings sleep.  A string under a plain damper whose pickups have
  fallen below ``decay_velocity`` and whose points move slower than ``damped_velocity`` (1e-4
  m/s) is held at rest, where the dampers' leak would let it creep back to its rest line for
  seconds, a little faster than the decay stop's bound, until its next note.  It acts with the
  decay stop off too, so the decay stop's column stays a measure of the stop alone.  Measured
  against the model without it (``damped_velocity`` = 0): the largest |difference| in dB of full
  scale, the share of ``WINDOW`` windows in which the output differs by more than the decay
  stop's tolerance, the median and the largest difference of a window's magnitude spectrum
  against the window's own (windows within 60 dB of the render's loudest), and the
  string-steps asleep without it.

``--sensitivity`` prints, for the songs, what the same measures give when every pluck's and
strum's force changes by a small fraction of itself (``SENSITIVITY``): how far below what a score
specifies a render's samples already move, the scale against which to read the damped rest's.

Each row: the string-steps run in the kernel's general step, in plain runs and asleep (of all
the strings' steps, as rendered); for the damper bound, the collision point-steps tested with it
and without it; for the decay stop, the largest |difference| of the mixed output (m/s), the same
in dB of the render's peak and of full scale.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from engine.output import FIXED_GAIN
from engine.waveguide import WaveguideOptions
from tools.song_scene import song_scene

CORPUS = Path(__file__).resolve().parent.parent / ".cache" / "score-corpus"
SONGS = ("gp/Demo v5.gp5", "gp/001_Funky_Guy.gp5", "gp/Slides.gp5", "gp/Strokes.gp5")
TOLERANCE_DB_FS = -140.0  # the decay stop's bound, dB of full scale after the fixed gain
TOLERANCE = 10.0 ** (TOLERANCE_DB_FS / 20.0) / FIXED_GAIN  # the same in m/s of the output
WINDOW = 0.05  # s: the damped rest's windows (``windows``)
SENSITIVITY = (1e-6, 1e-4, 1e-2)  # ``--sensitivity``: relative changes of every force


def render(scene, **switches) -> tuple[np.ndarray, dict[str, int]]:
    """The mixed output (``engine.mix``, as the CLI renders it) with the waveguide's switches
    (``WaveguideVoice.set_switches``: ``skip_decayed``, ``steady_runs``, ``damper_bound``,
    ``damped_velocity``; the options' defaults otherwise) and the string-steps of each kind:
    ``general``, ``plain``, ``slept`` and ``all``; ``tested``: the collision point-steps tested;
    ``rests``: the damped rests."""
    from engine.mix import prepare

    mix = prepare(scene)
    voices = [v for t in mix.tracks for v in t.instrument.voices]
    for v in voices:
        v.set_switches(**switches)
    parts = list(mix.blocks())
    out = np.concatenate(parts) if parts else np.zeros(0)
    steps = {"general": sum(int(v.st["general"]) for v in voices),
             "plain": sum(int(v.st["plain"]) for v in voices),
             "slept": sum(v.steps_slept for v in voices),
             "tested": sum(int(v.st["tested"]) for v in voices),
             "rests": sum(int(v.st["rests"]) for v in voices),
             "all": len(voices) * mix.frames}
    return out, steps


def difference(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """max |a - b| and that in dB of b's peak (-inf when equal)."""
    d = float(np.max(np.abs(a - b))) if a.size else 0.0
    peak = float(np.max(np.abs(b))) if b.size else 0.0
    return d, (20.0 * np.log10(d / peak) if d > 0.0 and peak > 0.0 else -np.inf)


def db_full_scale(d: float) -> float:
    """A difference of the output (m/s) in dB of full scale after the fixed gain."""
    return 20.0 * np.log10(d * FIXED_GAIN) if d > 0.0 else -np.inf


def windows(a: np.ndarray, b: np.ndarray, rate: float) -> tuple[float, float, float]:
    """How a differs from b window by window (``WINDOW`` s, Hann, hop half a window): the share
    of windows whose largest |a - b| exceeds ``TOLERANCE``, and the median and the largest
    difference of a's magnitude spectrum from b's against b's, in dB, over b's windows within
    60 dB of its loudest (-inf when a equals b)."""
    n = int(WINDOW * rate)
    hop = n // 2
    starts = range(0, max(len(b) - n, 0) + 1, hop)
    over = sum(float(np.max(np.abs(a[i:i + n] - b[i:i + n]))) > TOLERANCE for i in starts)
    hann = np.hanning(n)[:, None] if b.ndim == 2 else np.hanning(n)  # stereo: both channels
    loudest, spectra = 0.0, []
    for i in starts:
        ma = np.abs(np.fft.rfft(hann * a[i:i + n], axis=0))
        mb = np.abs(np.fft.rfft(hann * b[i:i + n], axis=0))
        level = float(np.sqrt(np.sum(mb * mb)))
        spectra.append((float(np.sqrt(np.sum((ma - mb) ** 2))), level))
        loudest = max(loudest, level)
    rel = [20.0 * np.log10(diff / level) if diff > 0.0 else -np.inf
           for diff, level in spectra if level > 1e-3 * loudest]
    if not rel:
        return over / max(len(starts), 1), -np.inf, -np.inf
    return over / max(len(starts), 1), float(np.median(rel)), max(rel)


def rows(scenes: dict) -> list[str]:
    out = []
    for name, scene in scenes.items():
        a, steps = render(scene)
        n = max(steps["all"], 1)
        share = (f"{steps['general'] / n:7.1%} {steps['plain'] / n:7.1%} "
                 f"{steps['slept'] / n:7.1%}")
        b, _ = render(scene, steady_runs=False)
        d1, _ = difference(a, b)
        c, _ = render(scene, skip_decayed=False)
        d2, db2 = difference(a, c)
        fs_db = db_full_scale(d2)
        e, wide = render(scene, damper_bound=False)
        d3, _ = difference(a, e)
        tested = f"{steps['tested']:.3g} / {wide['tested']:.3g}"
        g, creep = render(scene, damped_velocity=0.0)
        d4, _ = difference(a, g)
        db4 = db_full_scale(d4)
        moved, typical, spectral = windows(a, g, scene.sample_rate)
        out.append(f"{name[:34]:34s} | {share} | {'exact' if d1 == 0.0 else f'{d1:.2e}':>11s} | "
                   f"{'exact' if d3 == 0.0 else f'{d3:.2e}':>9s} {tested:>19s} | "
                   f"{d2:9.2e} {db2:7.1f} dB {fs_db:7.1f} dB FS | "
                   f"{steps['rests']:5d} {db4:7.1f} dB FS {moved:6.1%} {typical:7.1f} / "
                   f"{spectral:6.1f} dB "
                   f"{creep['slept'] / n:7.1%}")
    return out


def sensitivity_rows(scenes: dict) -> list[str]:
    """Each song rendered with every pluck's and strum's force times 1 + r for r in
    ``SENSITIVITY``, against the song as it is: the measures of the damped rest's columns."""
    out = []
    for name, scene in scenes.items():
        a, _ = render(scene)
        for rel in SENSITIVITY:
            changed = scene.model_copy(deep=True)
            for events in ([t.events for t in changed.tracks] if changed.tracks
                           else [changed.events]):
                for e in events:
                    if e.type in ("pluck", "strum"):
                        e.force *= 1.0 + rel
            b, _ = render(changed)
            d, _ = difference(b, a)
            db = db_full_scale(d)
            moved, typical, worst = windows(b, a, scene.sample_rate)
            out.append(f"{name[:34]:34s} | forces x (1 + {rel:g}) | {db:7.1f} dB FS "
                       f"{moved:6.1%} {typical:7.1f} / {worst:6.1f} dB")
    return out


def main() -> None:
    import engine
    from tools.render_digest import WAVEGUIDE

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("files", nargs="*", help=f"songs (default: {', '.join(SONGS)} of the corpus)")
    ap.add_argument("--seconds", type=float, default=20.0, help="each song's first S seconds")
    ap.add_argument("--sensitivity", action="store_true",
                    help="instead: the songs with every force changed by a small fraction")
    args = ap.parse_args()
    if args.seconds <= 0:
        ap.error("--seconds must be > 0")
    files = args.files or [str(CORPUS / s) for s in SONGS]
    scenes = {f"{Path(f).name} ({args.seconds:g} s)": song_scene(f, args.seconds) for f in files}
    if args.sensitivity:
        print(f"{'song':34s} | change | max |diff|, {WINDOW * 1e3:g} ms windows over "
              f"{TOLERANCE_DB_FS:g} dB FS, spectral difference (median / largest window)")
        for row in sensitivity_rows(scenes):
            print(row)
        return
    scenes.update({name: engine.parse_scene({**sc, "model": "waveguide"})
                   for name, sc in WAVEGUIDE.items()})
    print(f"tolerance of the decay stop: {TOLERANCE_DB_FS:g} dB of full scale = {TOLERANCE:.1e} "
          "m/s of the output; steady runs and the damper bound: exact")
    print(f"{'scene':34s} | general   plain   slept | steady runs | damper bound, "
          "point-steps tested | decay stop: max |diff|, re peak, re full scale | damped rest "
          f"(damped_velocity {WaveguideOptions.damped_velocity:g} m/s) against none: rests, "
          f"max |diff|, {WINDOW * 1e3:g} ms windows over the tolerance, spectral difference "
          "(median / largest window), slept without it")
    for row in rows(scenes):
        print(row)


if __name__ == "__main__":
    main()
