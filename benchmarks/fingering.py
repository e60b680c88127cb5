"""Fingering of MIDI files: the Viterbi search (``engine.score.fingering.viterbi``) against the
greedy lowest-fret baseline, on the MIDI test files (``make test-data`` puts them in
``.cache/score-corpus/midi``).  Prints, per file and in total, the mean fret movement of the hand
per note and the notes that needed a compromise (moved by an octave, left out, cut short, or in a
chord wider than five frets).

    python -m benchmarks.fingering [FILES...]
"""

from __future__ import annotations

import glob
import os
import sys
import warnings

from engine import presets
from engine.score import common, fingering

CORPUS = os.path.join(os.path.dirname(__file__), "..", ".cache", "score-corpus", "midi")


def parts(path: str):
    """(name, preset, times, ends, pitches) of every pitched part of a MIDI file."""
    import pretty_midi

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        pm = pretty_midi.PrettyMIDI(path)
    for inst in pm.instruments:
        if inst.is_drum or not inst.notes:
            continue
        notes = sorted(inst.notes, key=lambda n: (n.start, n.pitch))
        yield (common.preset_for_program(inst.program), [n.start for n in notes],
               [n.end for n in notes], [n.pitch for n in notes])


def main(files: list[str]) -> None:
    files = files or sorted(glob.glob(os.path.join(CORPUS, "*.mid")))
    if not files:
        sys.exit(f"no MIDI files: run `make test-data` (looked in {CORPUS})")
    print(f"{'file':<20} {'notes':>6} | {'greedy move/note':>16} {'compromises':>11} | "
          f"{'viterbi move/note':>17} {'compromises':>11}")
    tot = {"greedy": [0.0, 0, 0], "viterbi": [0.0, 0, 0]}
    for path in files:
        row = {}
        n_notes = 0
        for preset, times, ends, pitches in parts(path):
            tuning = common.preset_tuning(preset)
            frets = presets.get_preset(preset).frets
            n_notes += len(times)
            for name, fn in (("greedy", fingering.greedy), ("viterbi", fingering.viterbi)):
                m = fingering.measure(fn(times, ends, pitches, tuning, frets), times)
                r = row.setdefault(name, [0.0, 0, 0])
                r[0] += m["mean_move"] * m["placed"]
                r[1] += m["placed"]
                r[2] += m["compromises"]
        for name in row:
            for k in range(3):
                tot[name][k] += row[name][k]
        g, v = row["greedy"], row["viterbi"]
        print(f"{os.path.basename(path):<20} {n_notes:>6} | {g[0] / max(g[1], 1):>16.3f} "
              f"{g[2]:>11} | {v[0] / max(v[1], 1):>17.3f} {v[2]:>11}")
    g, v = tot["greedy"], tot["viterbi"]
    print(f"{'all':<20} {g[1]:>6} | {g[0] / max(g[1], 1):>16.3f} {g[2]:>11} | "
          f"{v[0] / max(v[1], 1):>17.3f} {v[2]:>11}")


if __name__ == "__main__":
    main(sys.argv[1:])
