"""Extract the third-party score files the tests use from the sdists `make test-data` downloads
into DIR/sdist: PyGuitarPro's own test corpus (.gp3/.gp4/.gp5) into DIR/gp, the MIDI test files of
music21 and miditoolkit into DIR/midi, and music21's MusicXML (the LilyPond MusicXML test suite,
its tablature tests and a slice of its corpus: .xml and compressed .mxl) into DIR/musicxml.
Nothing here is committed (.cache/ is ignored).

No package on PyPI, Debian or npm carries Guitar Pro 6/7/8 (.gpx/.gp) files; the tests build those
from the .gp5 files (tests/engine/score/gpif_writer.py).

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
# music21's MusicXML: the LilyPond test suite, its tab tests, and corpus folders of chamber and
# choral music (.mxl), a second rule for the same sdist
MUSICXML = ("musicxml", lambda p: ("/musicxml/lilypondTestSuite/" in p and p.endswith(".xml"))
            or p.endswith("/musicxml/testTab.xml")
            or any(f"/corpus/{c}/" in p for c in ("demos", "schumann_clara", "haydn/opus1no1",
                                                   "beethoven/opus18no1", "mozart/k80"))
            and p.endswith((".mxl", ".xml", ".musicxml")))


def main(root: str) -> None:
    counts = {}
    for sdist in sorted(glob.glob(os.path.join(root, "sdist", "*.tar.gz"))):
        base = os.path.basename(sdist).lower()
        rules = [v for k, v in WANT.items() if base.startswith(k)]
        if base.startswith("music21-"):
            rules.append(MUSICXML)
        for kind, _ in rules:
            os.makedirs(os.path.join(root, kind), exist_ok=True)
        if not rules:
            continue
        with tarfile.open(sdist) as tar:
            for m in tar.getmembers():
                for kind, keep in rules:
                    if m.isfile() and keep(m.name):
                        out = os.path.join(root, kind, os.path.basename(m.name))
                        with tar.extractfile(m) as src, open(out, "wb") as dst:
                            dst.write(src.read())
                        counts[kind] = counts.get(kind, 0) + 1
    if not counts.get("gp") or not counts.get("midi") or not counts.get("musicxml"):
        sys.exit(f"score corpus incomplete in {root}: {counts}")
    print(f"score corpus in {root}: {counts}")


if __name__ == "__main__":
    main(sys.argv[1])
