"""What each skip saves and what it changes: speed-up and largest output difference.

For every way the engine avoids work, the same scene is rendered with the skip on and off:

* silent strings: strings with no events are not simulated;
* contacts: rigid frets are evaluated only when one is within reach this step (the linear pass
  counts the nodes below the fretboard and within reach of a fret tip), and steps in which
  nothing but the string acts and no contact happens run in ``kernels._quiet_run`` (both sides
  with Kirchhoff-Carrier in every step: exact); a last table gives the share of such quiet steps;
* held steps: the steps of a fretted note in which one finger presses the string onto the frets
  it rests on, and nothing changes which forces act, run in ``kernels._held_run`` (the general
  path's arithmetic, compiled the same way: exact, ``tests/engine/test_held.py``);
* Kirchhoff-Carrier below tolerance: quiet steps leave the column out while its tension rise is
  below ``kc_tolerance`` x T0 (``standard``: 1e-4); its own table gives the pitch this moves;
* decayed strings: a string stops once every node (and finger) moves slower than 1e-7 m/s after
  its last event.

    python -m benchmarks.skips

Differences are in output units at the fixed gain (full scale 1.0), i.e. pickup velocity x 0.25.
"""

from __future__ import annotations

import time

import numpy as np

from engine.fd.instrument import prepare
from engine.options import RenderOptions
from engine.output import FIXED_GAIN
from engine.scene import Scene
from engine.testing.measure import held_share, kc_skip_pitch_shift, quiet_share
from engine.testing.scenes import chord_events, fretted_events, strum_events


def render(scene: dict, **opts) -> tuple[np.ndarray, float]:
    eng = prepare(Scene.model_validate(scene), RenderOptions(**opts))
    t = time.perf_counter()
    out = np.concatenate(list(eng.blocks()))
    return out * FIXED_GAIN, time.perf_counter() - t


SINGLE_NOTE = {"duration": 4.0, "events": [{"type": "pluck", "time": 0.0, "string": 3}]}
STRUM = {"duration": 2.0, "events": strum_events()}
HARD_STRUM = {"duration": 2.0, "events": strum_events(8.0)}
SHORT_NOTES = {
    "duration": 10.0,
    "guitar": {"strings": [{"string": s, "t60_fundamental_s": 0.6, "t60_2khz_s": 0.2}
                           for s in range(1, 7)]},
    "events": [{"type": "pluck", "time": 0.3 * i, "string": 1 + i % 6, "force": 2.0}
               for i in range(6)],
}
# Fingers striking the strings at the top of the allowed speed: the unreachable-fret skip is exact
# here only because string.fret_margin bounds the fingers too (docs/accuracy.md, "Defects found").
FAST_TAPS = {"duration": 1.0, "quality": "draft", "events": [
    {"type": "tap", "time": 0.1 * (s - 1), "string": s, "fret": 5, "force": 10.0, "velocity": 5.0}
    for s in range(1, 7)]}
MELODY_THEN_REST = {"duration": 15.0, "guitar": {"preset": "nylon-classical"}, "events": [
    {"type": "fret", "time": 0.0, "string": 2, "fret": 1},
    {"type": "pluck", "time": 0.05, "string": 2, "force": 2.0},
    {"type": "fret", "time": 0.5, "string": 2, "fret": 3},
    {"type": "pluck", "time": 0.55, "string": 2, "force": 2.0},
    {"type": "fret", "time": 1.0, "string": 2, "fret": 0},
]}
C_CHORD = {"duration": 2.0, "events": chord_events()}
FRETTED_8N = {"duration": 2.0, "events": fretted_events(4)}

# the contacts rows compare exact skips (held steps included): Kirchhoff-Carrier in every step
EXACT_KC = {"kc_tolerance": 0.0}

CASES = [
    ("silent strings", "one note on string 3, 4 s", SINGLE_NOTE,
     {"skip_silent": False, "skip_decayed": False}, {"skip_decayed": False}),
    ("contacts", "open strum 2 N, 2 s", STRUM, {"skip_contacts": False, **EXACT_KC}, EXACT_KC),
    ("contacts", "open strum 8 N, 2 s", HARD_STRUM, {"skip_contacts": False, **EXACT_KC}, EXACT_KC),
    ("contacts", "6 taps 10 N, 5 m/s, draft, 1 s", FAST_TAPS,
     {"skip_contacts": False, **EXACT_KC}, EXACT_KC),
    ("held steps", "fretted C chord 2 N, 2 s", C_CHORD, {"held_steps": False}, {}),
    ("held steps", "string 4 fret 5, 8 N, 2 s", FRETTED_8N, {"held_steps": False}, {}),
    ("KC below 1e-4 T", "open strum 2 N, 2 s", STRUM, EXACT_KC, {}),
    ("KC below 1e-4 T", "open strum 8 N, 2 s", HARD_STRUM, EXACT_KC, {}),
    ("decayed strings", "6 short notes (T60 0.6 s), 10 s", SHORT_NOTES,
     {"skip_decayed": False}, {}),
    ("decayed strings", "nylon B string melody, rest, 15 s", MELODY_THEN_REST,
     {"skip_decayed": False}, {}),
]


def kc_table() -> None:
    print("\nKirchhoff-Carrier skip, quality 'standard' (tolerance 1e-4 T: bound 0.087 cents): "
          "pitch of the fundamental over 0.5-2 s, skip on minus skip off (cents)")
    print("string | 2 N pluck | 8 N pluck")
    for s_ in range(1, 7):
        print(f"{s_:>6d} | {kc_skip_pitch_shift(s_, 2.0)[0]:+9.4f} | "
              f"{kc_skip_pitch_shift(s_, 8.0)[0]:+9.4f}")


def main() -> None:
    for scene in (SINGLE_NOTE, FAST_TAPS):  # load the compiled kernels before timing anything
        render({**scene, "duration": 0.6})
    print("skip              | scene                           | time off | time on | speed-up |"
          " max |difference| | peak")
    for skip, name, scene, off, on in CASES:
        a, t_on = render(scene, **on)
        b, t_off = render(scene, **off)
        diff = float(np.max(np.abs(a - b)))
        print(f"{skip:17s} | {name:31s} | {t_off:7.2f}s | {t_on:6.2f}s | {t_off / t_on:7.1f}x |"
              f" {diff:17.2e} | {np.abs(b).max():.3f}")
    kc_table()
    quiet_table()
    held_table()


def quiet_table(seconds: float = 2.0) -> None:
    print(f"\nquiet steps: share of each string's steps in an open strum, {seconds:g} s, quality "
          "'standard'")
    print("string | 2 N pluck | 8 N pluck")
    share = {force: quiet_share(force, seconds) for force in (2.0, 8.0)}
    for s in range(1, 7):
        print(f"{s:>6d} | {share[2.0][s]:9.4f} | {share[8.0][s]:9.4f}")


def held_table() -> None:
    print("\nheld steps: share of each string's steps, quality 'standard'")
    print("string | fretted C chord, 2 s | string 4 fret 5, 8 N, 2 s")
    chord, note = held_share(C_CHORD), held_share(FRETTED_8N)
    for s in range(1, 7):
        print(f"{s:>6d} | {chord[s]:20.4f} | " + (f"{note[s]:25.4f}" if s in note else f"{'':25s}"))


if __name__ == "__main__":
    main()
