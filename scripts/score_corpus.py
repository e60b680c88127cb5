"""Extract the third-party score files the tests use from the sdists `make test-data` downloads
into DIR/sdist: PyGuitarPro's own test corpus (.gp3/.gp4/.gp5) into DIR/gp, and the MIDI test
files of music21 and miditoolkit into DIR/midi.  Nothing here is committed (.cache/ is ignored).

    python scripts/score_corpus.py DIR
"""

from __future__ import annotations

import glob
import os
import sys
import tarfile

WANT = {
    "pyguitarpro-": ("gp", lambda p: "/tests/" in p and p.rsplit(".", 1)[-1] in ("gp3", "gp4", "gp5")),
    "music21-": ("midi", lambda p: ("/midi/testPrimitive/" in p or "/omr/" in p) and p.endswith(".mid")),
    "miditoolkit-": ("midi", lambda p: "/examples_data/" in p and p.endswith(".mid")),
}


def main(root: str) -> None:
    counts = {}
    for sdist in sorted(glob.glob(os.path.join(root, "sdist", "*.tar.gz"))):
        base = os.path.basename(sdist).lower()
        rule = next((v for k, v in WANT.items() if base.startswith(k)), None)
        if rule is None:
            continue
        kind, keep = rule
        os.makedirs(os.path.join(root, kind), exist_ok=True)
        with tarfile.open(sdist) as tar:
            for m in tar.getmembers():
                if m.isfile() and keep(m.name):
                    out = os.path.join(root, kind, os.path.basename(m.name))
                    with tar.extractfile(m) as src, open(out, "wb") as dst:
                        dst.write(src.read())
                    counts[kind] = counts.get(kind, 0) + 1
    if not counts.get("gp") or not counts.get("midi"):
        sys.exit(f"score corpus incomplete in {root}: {counts}")
    print(f"score corpus in {root}: {counts}")


if __name__ == "__main__":
    main(sys.argv[1])
