"""A long song renders in bounded memory: peak memory of ``engine.blocks`` over a multi-track scene
of sparse notes, for several durations (10 minutes by default).

    python -m benchmarks.long_song [--minutes 10] [--quality draft]

Prints, per duration: the render time, times real time, and the peak of Python's traced memory
(tracemalloc: numpy's arrays included) while the blocks stream, next to the size of the output
(which ``engine.blocks`` never holds: each block is dropped once handed on).
"""

from __future__ import annotations

import argparse
import time
import tracemalloc

import numpy as np

import engine


def song(seconds: float, quality: str = "draft", note_every_s: float = 4.0) -> dict:
    """Two tracks (an electric lead through drive, delay and reverb, and a bass), one plucked and
    damped note per track every ``note_every_s`` seconds, on strings that change from note to note."""
    lead, bass = [], []
    t = 0.0
    i = 0
    while t + note_every_s <= seconds:
        s = 1 + i % 3
        lead += [{"type": "fret", "time": t, "string": s, "fret": 2 + i % 5},
                 {"type": "pluck", "time": t + 0.01, "string": s},
                 {"type": "damp", "time": t + 0.8, "string": s}]
        bass += [{"type": "pluck", "time": t + 0.5 * note_every_s, "string": 1 + i % 2},
                 {"type": "damp", "time": t + 0.5 * note_every_s + 0.8, "string": 1 + i % 2}]
        t += note_every_s
        i += 1
    return {"duration": seconds, "quality": quality, "output": {"channels": 2},
            "tracks": [
                {"name": "Lead", "guitar": {"preset": "electric"}, "events": lead, "pan": -0.3,
                 "effects": [{"type": "drive", "gain_db": 12}, {"type": "delay", "delay_s": 0.3},
                             {"type": "reverb", "room_size": 0.6}]},
                {"name": "Bass", "guitar": {"preset": "bass"}, "events": bass, "pan": 0.2,
                 "gain_db": -3.0}]}


def stream_peak(scene: dict) -> tuple[float, float, int]:
    """(wall seconds, peak traced bytes, output bytes) of streaming the scene's blocks."""
    tracemalloc.start()
    t0 = time.perf_counter()
    frames = 0
    for block in engine.blocks(scene):
        frames += len(block)
        assert np.all(np.isfinite(block))
    seconds = time.perf_counter() - t0
    _, peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    return seconds, peak, frames * 2 * 8


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
