"""Every score of the test corpus (``make test-data``: PyGuitarPro's Guitar Pro files, music21's and
miditoolkit's MIDI files) through ``engine.score``: per file the tracks, the notes played, the
labels read back from the scene (they must be as many), the warnings, and the conversion time.

    python -m benchmarks.score_corpus
"""

from __future__ import annotations

import glob
import os
import sys
import time

from engine.score import ScoreError, scene_notes, score_to_scene

ROOT = os.path.join(os.path.dirname(__file__), "..", ".cache", "score-corpus")


def main() -> None:
    files = sorted(glob.glob(os.path.join(ROOT, "gp", "*.gp[345]"))) + sorted(
        glob.glob(os.path.join(ROOT, "midi", "*.mid")))
    if not files:
        sys.exit("no corpus: run `make test-data`")
    print(f"{'file':<28} {'tracks':>6} {'notes':>6} {'labels':>6} {'warnings':>8} {'s':>6}  result")
    tot = {"ok": 0, "refused": 0, "notes": 0, "labels": 0, "warnings": 0}
    for path in files:
        name = os.path.basename(path)
        t0 = time.perf_counter()
        try:
            scene = score_to_scene(path, all_instruments=True)
        except ScoreError as exc:
            tot["refused"] += 1
            print(f"{name:<28} {'':>6} {'':>6} {'':>6} {'':>8} {time.perf_counter() - t0:>6.2f}  "
                  f"ScoreError: {exc}"[:160])
            continue
        labels = scene_notes(scene)
        dt = time.perf_counter() - t0
        pitched = sum(1 for n in scene.notes if not n["dead"])
        tot["ok"] += 1
        tot["notes"] += pitched
        tot["labels"] += len(labels)
        tot["warnings"] += len(scene.warnings)
        ok = "labels = notes" if len(labels) == pitched else "MISMATCH"
        print(f"{name:<28} {len(scene['tracks']):>6} {pitched:>6} {len(labels):>6} "
              f"{len(scene.warnings):>8} {dt:>6.2f}  {ok}")
    print(f"converted {tot['ok']} files, refused {tot['refused']}; {tot['notes']} pitched notes, "
          f"{tot['labels']} labels, {tot['warnings']} warnings")


if __name__ == "__main__":
    main()
