"""Regenerate every benchmark table (the figures the README and docs/ quote).

    python -m benchmarks.run_all        # or: make bench

Each script prints its own table; this runs them in turn and writes the output to
benchmarks/out/<name>.txt as well as to the terminal.
"""

from __future__ import annotations

import contextlib
import io
import pathlib
import sys
import time

from benchmarks import accuracy, intonation, skips, speed

OUT = pathlib.Path(__file__).parent / "out"

RUNS = [
    ("speed", speed.main, ["--quality", "standard"]),
    ("speed_draft", speed.main, ["--quality", "draft"]),
    ("skips", skips.main, []),
    ("accuracy", accuracy.main, []),
    ("intonation_steel", intonation.main, ["--preset", "steel-acoustic"]),
    ("intonation_nylon", intonation.main, ["--preset", "nylon-classical"]),
]


def main() -> None:
    OUT.mkdir(exist_ok=True)
    for name, fn, argv in RUNS:
        t = time.perf_counter()
        buf = io.StringIO()
        sys.argv = [name, *argv]
        with contextlib.redirect_stdout(buf):
            fn()
        text = buf.getvalue()
        (OUT / f"{name}.txt").write_text(text)
        print(f"===== {name} ({time.perf_counter() - t:.0f} s)\n{text}", flush=True)


if __name__ == "__main__":
    main()
