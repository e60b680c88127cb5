"""Fingerprints of what preparing whole songs gives, to check that a change to the preparation of
strings (controls, timelines, tuning, warnings) changed nothing, and what it costs.

    python -m tools.controls_digest > before.json            # on the old tree
    python -m tools.controls_digest --check before.json      # on the new tree: exit 1 on a change

Every score of the test corpus (``make test-data``: PyGuitarPro's Guitar Pro files and the MIDI
files, all instruments played) becomes a scene, prepared on both models (``engine.mix.prepare``)
as a render prepares it.  Hashed: every voice's fields (the control arrays, scalars and finger
motions of the finite-difference model; the timelines of the waveguide), each instrument's
warnings and, for the finite-difference model, ``scene_warnings``.  A file the importer refuses
is recorded with its error's type.  The seconds each preparation took go to standard error with
the digests, so that one run gives both.

Run both trees with ``GUITAR_CALIBRATION_CACHE=0``: a fret calibration kept in the store can
differ from a fresh solve in the last bits, and a change to the sources its key hashes makes one
tree solve afresh where the other reads the store.
"""

from __future__ import annotations

import argparse
import copy
import dataclasses
import hashlib
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
CORPUS = ROOT / ".cache" / "score-corpus"
SKIP = {"test04.mid"}  # 16 parts: minutes to prepare with the calibration store off
SKIPPED_FIELDS = {"rebuild", "decimator", "scene", "preset", "_step_block", "options", "body"}


def _walk(h: Any, o: Any, depth: int = 0) -> None:
    if depth > 6:
        return
    if isinstance(o, np.ndarray):
        h.update(str(o.dtype).encode())
        h.update(np.ascontiguousarray(o).tobytes())
    elif isinstance(o, int | float | str | bool | type(None)):
        h.update(repr(o).encode())
    elif isinstance(o, list | tuple):  # (named tuples too)
        for x in o:
            _walk(h, x, depth + 1)
    elif isinstance(o, dict):
        for k in sorted(o, key=repr):
            h.update(repr(k).encode())
            _walk(h, o[k], depth + 1)
    elif dataclasses.is_dataclass(o):
        for f in dataclasses.fields(o):
            if f.name not in SKIPPED_FIELDS:
                _walk(h, getattr(o, f.name), depth + 1)


def digests() -> dict[str, str]:
    import engine
    from engine import mix
    from engine.fd.playability import scene_warnings
    from engine.score import score_to_scene

    files = sorted((CORPUS / "gp").glob("*.gp*")) + sorted((CORPUS / "midi").glob("*.mid"))
    if not files:
        sys.exit(f"no scores in {CORPUS}: make test-data")
    out: dict[str, str] = {}
    for f in files:
        if f.name in SKIP:
            continue
        try:
            imported = dict(score_to_scene(f, all_instruments=True))
        except Exception as exc:  # the importer's refusal is part of the record
            out[f.name] = f"import: {type(exc).__name__}"
            continue
        for model in ("fdtd", "waveguide"):
            d = copy.deepcopy(imported)
            d["model"] = model
            for t in d.get("tracks") or []:
                t.pop("model", None)
            scene = engine.Scene.model_validate(d)
            t0 = time.perf_counter()
            prepared = mix.prepare(scene)
            seconds = time.perf_counter() - t0
            h = hashlib.sha256()
            for track in prepared.tracks:
                _walk(h, track.instrument.voices)
                _walk(h, track.instrument.warnings())
            if model == "fdtd":
                _walk(h, scene_warnings(scene))
            key = f"{f.name}:{model}"
            out[key] = h.hexdigest()[:16]
            print(f"{f.name:40s} {model:9s} prepared in {seconds:6.2f} s  {out[key]}",
                  file=sys.stderr, flush=True)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--check", metavar="JSON", help="compare with a digest printed earlier")
    a = ap.parse_args()
    out = digests()
    if a.check is None:
        print(json.dumps(out, indent=0))
        return
    ref = json.loads(Path(a.check).read_text())
    differ = sorted(k for k in ref.keys() | out.keys() if ref.get(k) != out.get(k))
    print(f"{len(ref) - len(set(differ) & ref.keys())} of {len(ref)} identical"
          + (f"; differ: {differ}" if differ else ""))
    sys.exit(1 if differ else 0)


if __name__ == "__main__":
    main()
