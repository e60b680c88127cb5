"""Size of a score's JAMS labels: each note once (today's sandbox) against a full copy of every
note beside its observation (the layout before), indented as ``JAMS.save`` writes and compact as
``engine.save_labels`` writes, with and without the pitch contours.

    python -m benchmarks.label_size [SCORE ...]     (default: the corpus's Demo v5.gp5)
"""

from __future__ import annotations

import json
import sys
import time
from pathlib import Path

import jams  # noqa: F401 - imported before the clock starts (mir_eval, scipy: seconds)

from engine.score import scene_labels, scene_notes, score_to_scene

DEFAULT = Path(__file__).resolve().parents[1] / ".cache" / "score-corpus" / "gp" / "Demo v5.gp5"


def _sizes(doc: dict) -> tuple[int, int]:
    return len(json.dumps(doc, indent=2)), len(json.dumps(doc, separators=(",", ":")))


def main(paths: list[str]) -> None:
    print(f"{'score':24} {'notes':>6} {'frames':>7} {'copied, indented':>17} "
          f"{'once, indented':>15} {'once, compact':>14} {'+contours':>10} {'labels s':>9}")
    for path in paths or [str(DEFAULT)]:
        scene = score_to_scene(path, all_instruments=True)
        t0 = time.perf_counter()
        full = scene_labels(scene).__json__
        seconds = time.perf_counter() - t0
        plain = scene_labels(scene, contour_hop=None).__json__
        notes = scene_notes(scene)
        # the layout before: each annotation's sandbox.notes a full copy of every note
        by = {}
        for n in notes:
            by.setdefault((n["track"], n["string"]), []).append(n)
        copied = json.loads(json.dumps(plain))
        for ann in copied["annotations"]:
            if ann["namespace"] == "note_midi":
                sb = ann["sandbox"]
                sb["notes"] = by.get((sb["track"], sb["string"]), [])
        frames = sum(len(a["data"]["time"]) for a in full["annotations"]
                     if a["namespace"] == "pitch_contour")
        print(f"{Path(path).name[:24]:24} {len(notes):6d} {frames:7d} {_sizes(copied)[0]:17,d} "
              f"{_sizes(plain)[0]:15,d} {_sizes(plain)[1]:14,d} {_sizes(full)[1]:10,d} "
              f"{seconds:9.2f}")


if __name__ == "__main__":
    main(sys.argv[1:])
