"""A long song renders in bounded memory: peak memory of ``engine.blocks`` over a multi-track scene
of sparse notes, for several durations (10 minutes by default).

    python -m benchmarks.long_song [--minutes 10] [--quality draft]

Prints, per duration: the render time, times real time, and the peak of Python's traced memory
(tracemalloc: numpy's arrays included) while the blocks stream, next to the size of the output
(which ``engine.blocks`` never holds: each block is dropped once handed on).
"""

from __future__ import annotations

import argparse

import engine
from engine.testing.measure import stream_peak
from engine.testing.scenes import song


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--minutes", type=float, nargs="+", default=[1.0, 10.0])
    ap.add_argument("--quality", default="draft")
    args = ap.parse_args()
    engine.warmup()
    print("| duration | events | render s | x real time | peak traced MB | output MB (not held) |")
    print("| --- | --- | --- | --- | --- | --- |")
    for minutes in args.minutes:
        sc = song(60.0 * minutes, args.quality)
        n = sum(len(t["events"]) for t in sc["tracks"])
        secs, peak, out = stream_peak(sc)
        print(f"| {minutes:g} min | {n} | {secs:.1f} | {60 * minutes / secs:.1f} | "
              f"{peak / 1e6:.1f} | {out / 1e6:.1f} |", flush=True)


if __name__ == "__main__":
    main()
