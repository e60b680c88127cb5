"""Regenerate every benchmark table (the figures the README and docs/ quote).

    python -m benchmarks.run_all                 # or: make bench
    python -m benchmarks.run_all speed skips     # only these (after a change that moves timings)

Each script prints its own table; this runs them in turn and writes the output to
benchmarks/out/<name>.txt as well as to the terminal.  ``pareto`` and ``soak`` also rewrite their
sections of docs/accuracy.md and docs/img/pareto.png; the first table of each output named in
``DOCS`` is copied into docs/accuracy.md as printed (the rest stays in benchmarks/out/).
"""

from __future__ import annotations

import contextlib
import io
import pathlib
import sys
import time

from benchmarks import (
    accuracy,
    articulations,
    fret_modes,
    intonation,
    pareto,
    scores,
    seating,
    skips,
    soak,
    songs,
    speed,
)

OUT = pathlib.Path(__file__).parent / "out"

RUNS = [
    ("speed", speed.main, ["--quality", "standard"]),
    ("speed_draft", speed.main, ["--quality", "draft"]),
    ("skips", skips.main, []),
    ("accuracy", accuracy.main, []),
    ("articulations", articulations.main, []),
    ("intonation_steel", intonation.main, ["--preset", "steel-acoustic"]),
    ("intonation_nylon", intonation.main, ["--preset", "nylon-classical"]),
    ("fret_modes_steel", fret_modes.main, ["--preset", "steel-acoustic", "--quality", "draft"]),
    ("fret_modes_steel_standard", fret_modes.main,
     ["--preset", "steel-acoustic", "--quality", "standard"]),
    ("fret_modes_nylon", fret_modes.main, ["--preset", "nylon-classical", "--quality", "standard"]),
    ("seating_steel", seating.main, ["--preset", "steel-acoustic", "--quality", "standard"]),
    ("seating_nylon", seating.main, ["--preset", "nylon-classical", "--quality", "standard"]),
    ("pareto", pareto.main, []),
    ("soak", soak.main, ["--minutes", "3"]),
    ("songs", songs.main, []),  # whole songs against FluidSynth, and the cold start
    # last: it pins its process to one core
    ("scores", scores.main, []),
]
# outputs whose first table is copied verbatim into docs/accuracy.md (marker name -> section title)
# (fret_modes and seating print full grids to benchmarks/out/; docs/accuracy.md keeps their worst
# cases in a short table)
DOCS = {
    "skips": "Skips: speed-up and largest output difference",
}


def main() -> None:
    OUT.mkdir(exist_ok=True)
    only = set(sys.argv[1:])
    unknown = only - {name for name, _, _ in RUNS}
    if unknown:
        sys.exit(f"unknown benchmark(s) {sorted(unknown)}; choose from {[r[0] for r in RUNS]}")
    t0 = time.perf_counter()
    for name, fn, argv in RUNS:
        if only and name not in only:
            continue
        t = time.perf_counter()
        buf = io.StringIO()
        sys.argv = [name, *argv]
        with contextlib.redirect_stdout(buf):
            fn()
        text = buf.getvalue()
        (OUT / f"{name}.txt").write_text(text)
        if name in DOCS:
            command = " ".join(["python -m", fn.__module__, *argv])
            first = text.strip().split("\n\n")[0]
            pareto.write_docs(DOCS[name], name, f"The first table printed by `{command}`.\n\n"
                              f"```text\n{first}\n```")
        print(f"===== {name} ({time.perf_counter() - t:.0f} s)\n{text}", flush=True)
    print(f"===== all benchmarks: {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
