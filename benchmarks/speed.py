"""Cost of the engine on this machine: milliseconds of compute per second of audio.

Table 1, per string of the default preset at the chosen quality: the linear string alone (the
"baseline" of the paper's sec. 7), and the full model (Kirchhoff-Carrier, fretboard, rigid frets, a
finger pressing at fret 5, an 8 N pluck), with the ratio between them; and an open string's 2 N
pluck with every nonlinearity on against the same pluck on the linear string; then the floor of
table 2's open strum, fretted chord and melody (``scene_floor``: the strings each plays on the
grids it gives them, linear, computed throughout), the most a plain stencil on those grids allows.
Table 2, whole scenes: a six-string strum (open strings), a fretted chord (with held steps and
without: what the held run buys), a fretted single-line melody whose notes are damped as a player
ends them (with sleeping and stopping quiet strings, the default, and without), and the paper's
Table 1 configuration for comparison (their C++: 40-180 ms per second of audio per string).
Table 3, where a fretted string's time goes: each force switched on in turn, ns, cycles and
instructions per time step, and the time over the linear string's.  Table 4, the tension rise that
pressing alone gives each string: above the Kirchhoff-Carrier skip's level, a fretted note needs the
column in every step (which table 3's "KC in every step" rows price).

    python -m benchmarks.speed [--quality standard] [--seconds 4] [--repeat 3]

Timings are the best of ``--repeat`` runs of the simulation alone (scene preparation excluded; CPU
time of the rendering thread), on one core (the engine is single-threaded; the service runs one
render per worker process).  Where the machine gives hardware counters (``tools.counters``),
the tables also print the fewest CPU cycles and instructions of those runs: times move between
sessions on "the same" machine (``tools.counters``), and instructions do not move unless the
code or the scene does.
"""

from __future__ import annotations

import argparse

from engine.fd.instrument import prepare
from engine.fd.string import kc_skip_level
from engine.options import QUALITY, RenderOptions
from engine.scene import Scene
from engine.testing.scenes import (
    LINEAR,
    chord_events,
    fretted_events,
    pluck_events,
    strum_events,
)
from tools.timing import Timing, best_time


def _per(value: float | None, steps: float, width: int) -> str:
    return f"{value / steps:{width}.0f}" if value is not None else f"{'-':>{width}s}"


def _ratio(a: float | None, b: float | None, width: int) -> str:
    return f"{a / b:{width}.2f}" if a is not None and b is not None else f"{'-':>{width}s}"


# A fretted single line (a C major scale up and down, strings 3 to 1, never an open string), one
# note every 0.25 s, each stopped by a ``damp`` just before the next note: as a player ends notes.
MELODY = [(3, 5), (3, 7), (2, 5), (2, 6), (2, 8), (1, 5), (1, 7), (1, 8),
          (1, 7), (1, 5), (2, 8), (2, 6), (2, 5), (3, 7), (3, 5), (3, 7)]


def melody_events(note_s: float = 0.25) -> list[dict]:
    """``MELODY``: each note fretted, plucked 10 ms later and damped 20 ms before the next."""
    out = []
    for i, (s, q) in enumerate(MELODY):
        t = i * note_s
        out += [{"type": "fret", "time": t, "string": s, "fret": q},
                {"type": "pluck", "time": t + 0.01, "string": s, "force": 2.0},
                {"type": "damp", "time": t + note_s - 0.02, "string": s}]
    return out


def linear_time(string: int, oversample: int | None, quality: str, seconds: float,
                repeat: int) -> Timing:
    """The linear string (``LINEAR``), an 8 N pluck, at ``oversample`` (None: its own factor as an
    open string)."""
    sc = {"duration": seconds, "quality": quality, "output": {"body": "none"},
          "events": pluck_events(string, 8.0)}
    return best_time(sc, RenderOptions(oversample=oversample, **LINEAR), repeat)


def scene_floor(events: list[dict], quality: str, seconds: float, repeat: int,
                timed: dict[tuple[int, int], float]) -> float:
    """The floor of a scene: seconds of compute per second of audio of the strings it plays, each
    on the grid the scene gives it (fingered or not), linear (no contact, no Kirchhoff-Carrier,
    no body) and computed throughout (no sleeping or stopping).  ``timed``: seconds per second of
    the linear string at a factor, by (string, factor), filled as strings are timed."""
    sc = Scene.model_validate({"duration": seconds, "quality": quality, "events": events,
                               "output": {"body": "none"}})
    total = 0.0
    for v in prepare(sc, RenderOptions(calibrate_frets=False)).voices:  # the grids only
        if (v.index, v.oversample) not in timed:
            t = linear_time(v.index, v.oversample, quality, seconds, repeat)
            timed[v.index, v.oversample] = t.seconds / seconds
        total += timed[v.index, v.oversample]
    return total


def per_string(quality: str, seconds: float, repeat: int) -> None:
    print(f"\nper string, quality '{quality}', {seconds:g} s of audio at 44.1 kHz (ms of compute per "
          "second of audio; body 'none')")
    print("The fretted full model (finger at fret 5, 8 N pluck) runs at the factor x the quality "
          "gives a fingered string;\nthe linear string is timed at that same factor (the "
          "nonlinearities' own cost) and at its own factor.\nOpen: a 2 N pluck of the open string "
          "with every nonlinearity on, against the linear string, both at the open string's own x.")
    print("string | x |   N | linear, same x | linear, own x | fretted full | fretted / linear "
          "(same x) | in cycles | in instructions | open full / linear | in instructions")
    timed: dict[tuple[int, int], float] = {}  # the linear strings, for the scenes' floors
    for s in range(1, 7):
        base = {"duration": seconds, "quality": quality, "output": {"body": "none"}}
        full = {**base, "events": fretted_events(s)}
        soft = {**base, "events": pluck_events(s, 2.0)}
        t_full = best_time(full, RenderOptions(skip_decayed=False), repeat)
        v = t_full.engine.voices[0]
        t_same = linear_time(s, v.oversample, quality, seconds, repeat)
        t_own = linear_time(s, None, quality, seconds, repeat)
        t_open = best_time(soft, RenderOptions(skip_decayed=False), repeat)
        t_soft_lin = best_time(soft, RenderOptions(**LINEAR), repeat)
        timed[s, v.oversample] = t_same.seconds / seconds
        timed[s, t_own.engine.voices[0].oversample] = t_own.seconds / seconds
        print(f"{s:>6d} | {v.oversample:>1d} | {v.coefs.n:>3d} | "
              f"{t_same.seconds / seconds * 1e3:14.1f} | {t_own.seconds / seconds * 1e3:13.1f} | "
              f"{t_full.seconds / seconds * 1e3:12.1f} | "
              f"{t_full.seconds / t_same.seconds:24.2f} | "
              f"{_ratio(t_full.cycles, t_same.cycles, 9)} | "
              f"{_ratio(t_full.instructions, t_same.instructions, 15)} | "
              f"{t_open.seconds / t_soft_lin.seconds:18.2f} | "
              f"{_ratio(t_open.instructions, t_soft_lin.instructions, 15)}")
    print("the floor of a scene: the strings it plays on its grids, linear (no contact, no "
          "Kirchhoff-Carrier, no body), computed throughout")
    for name, events in (("fretted C chord (fretted strings at x, open at own x)", chord_events()),
                         ("open strum (own x)", strum_events()),
                         ("fretted melody, damped note endings (strings 1-3 at x)",
                          melody_events(seconds / len(MELODY)))):
        floor = scene_floor(events, quality, seconds, repeat, timed)
        print(f"  {name}: {floor * 1e3:.1f} ms per s of audio, {1.0 / floor:.1f}x "
              "real time at most")


def components(seconds: float, repeat: int, string: int = 4) -> None:
    """Where a fretted string's time goes: each force added in turn, at 1x (per time step), and
    each row's time over the linear string's (the first row)."""
    print(f"\nwhere the time goes: string {string} at x1, finger at fret 5, 8 N pluck, body 'none' "
          "(compute per time step)")
    base = {"duration": seconds, "output": {"body": "none"}}
    pluck = {"type": "pluck", "time": 0.05, "string": string, "force": 8.0}
    open_ = {**base, "events": [pluck]}
    fretted = {**base, "events": [{"type": "fret", "time": 0.0, "string": string, "fret": 5},
                                  pluck]}
    off = {"kirchhoff_carrier": False, "fretboard": False, "frets": False}
    rows = [
        ("open string, linear", open_, off),
        ("open string, + Kirchhoff-Carrier", open_, {**off, "kirchhoff_carrier": True}),
        ("the same, KC in every step", open_,
         {**off, "kirchhoff_carrier": True, "kc_tolerance": 0.0}),
        ("open string, full model", open_, {}),
        ("open string, full model, KC in every step", open_, {"kc_tolerance": 0.0}),
        ("fretted: finger only", fretted, off),
        ("fretted: finger + rigid frets", fretted, {**off, "frets": True}),
        ("fretted: + fretboard", fretted, {"kirchhoff_carrier": False}),
        ("fretted: full model (+ Kirchhoff-Carrier)", fretted, {}),
        ("the same, held steps in the general path", fretted, {"held_steps": False}),
    ]
    print("configuration                              | ns per step | / linear | cycles per step | "
          "instructions per step")
    first = None
    for name, sc, opts in rows:
        t = best_time(sc, RenderOptions(oversample=1, skip_decayed=False, **opts), repeat)
        steps = seconds * t.engine.scene.sample_rate
        first = first or t.seconds
        print(f"{name:42s} | {t.seconds / steps * 1e9:11.0f} | {t.seconds / first:8.2f} | "
              f"{_per(t.cycles, steps, 15)} | {_per(t.instructions, steps, 21)}")


def pressed_tension_rise(quality: str, seconds: float = 0.5) -> None:
    """The Kirchhoff-Carrier tension rise of a string pressed at fret 5 and not plucked, after
    ``seconds``: what the static shape alone adds, against the level below which the quiet steps
    leave the column out (``string.kc_skip_level``, the quality's ``kc_tolerance``)."""
    sc = Scene.model_validate({"duration": seconds, "quality": quality, "output": {"body": "none"},
                               "events": [{"type": "fret", "time": 0.0, "string": s, "fret": 5}
                                          for s in range(1, 7)]})
    eng = prepare(sc, RenderOptions(skip_decayed=False))
    for _block in eng.blocks():
        pass
    tol = QUALITY[quality].kc_tolerance
    print(f"\na string pressed at fret 5, not plucked, after {seconds:g} s: its Kirchhoff-Carrier "
          f"tension rise over T0 (quality '{quality}' leaves the column out of quiet steps below "
          f"{tol:g})")
    print("string | rise / T0 | / skip level")
    for v in eng.voices:
        # S as the kernel's pass last took it (``State.s_last``), the number the skip decides on
        rise = float(v.state.s_last[0]) / kc_skip_level(v.model, 1.0)
        level = f"{rise / tol:12.1f}" if tol > 0 else f"{'-':>12s}"
        print(f"{v.index:>6d} | {rise:9.2e} | {level}")


def scenes(quality: str, seconds: float, repeat: int) -> None:
    strum, chord, melody = strum_events(), chord_events(), melody_events(seconds / len(MELODY))
    paper = [{"type": "fret", "time": 0.0, "string": 6, "fret": 5},
             {"type": "pluck", "time": 0.05, "string": 6, "force": 5.0}]
    print(f"\nscenes, quality '{quality}', {seconds:g} s of audio (with the preset's acoustic body)")
    print("scene                                    | ms per s of audio | x real time | "
          "Mcycles per s of audio")
    for name, evs, opts in [
        ("six-string strum (open)", strum, RenderOptions(skip_decayed=False)),
        ("the same, KC in every step", strum, RenderOptions(skip_decayed=False, kc_tolerance=0.0)),
        ("fretted C chord, strummed", chord, RenderOptions(skip_decayed=False)),
        ("the same, held steps in the general path", chord,
         RenderOptions(skip_decayed=False, held_steps=False)),
        ("fretted melody, damped note endings", melody, RenderOptions()),
        ("the same, quiet strings computed", melody, RenderOptions(skip_decayed=False)),
        ("paper Table 1 setup, low E", paper, RenderOptions(skip_decayed=False)),
    ]:
        t = best_time({"duration": seconds, "quality": quality, "events": evs}, opts, repeat)
        print(f"{name:40s} | {t.seconds / seconds * 1e3:17.1f} | {seconds / t.seconds:11.1f} | "
              f"{_per(t.cycles, seconds * 1e6, 22)}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quality", default="standard", choices=["draft", "standard", "high"])
    ap.add_argument("--seconds", type=float, default=4.0)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    per_string(args.quality, args.seconds, args.repeat)
    scenes(args.quality, args.seconds, args.repeat)
    components(args.seconds, args.repeat)
    pressed_tension_rise(args.quality)


if __name__ == "__main__":
    main()
