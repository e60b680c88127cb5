"""What one live block costs the live worker's audio thread, blocks with events against blocks
without: the peaks that make a block late, which a session's average CPU (``benchmarks.live``) hides.

One ``engine.Session`` per model, as the live worker holds it (the default guitar, 44.1 kHz,
256-frame blocks, ``draft``), played in-process with no server: every ``--every`` blocks a group of
events arrives in one block, as a musician's client sends them (a fret, its pluck and a slide; a
strum; a bend; a hammer-on; a mute; a release), the groups in turn.  The thread's CPU time of each
``block()`` (which applies the block's events, then computes it) is printed as the median, p99 and
longest, for blocks with events and for the others.  A live block is due every 5.8 ms and is sent
20 ms ahead of when it plays (``GUITAR_LIVE_LEAD_MS``).

    python -m benchmarks.live_blocks [--blocks 4000] [--every 13]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

GROUPS = [
    [{"type": "fret", "string": 3, "fret": 11}, {"type": "pluck", "string": 3, "force": 1.7},
     {"type": "slide", "string": 3, "from_fret": 11, "to_fret": 14, "duration": 0.1}],
    [{"type": "fret", "string": 4, "fret": 5}, {"type": "pluck", "string": 4, "force": 0.8}],
    [{"type": "strum", "direction": "down", "force": 1.5}],
    [{"type": "fret", "string": 2, "fret": 7}, {"type": "pluck", "string": 2},
     {"type": "bend", "string": 2, "semitones": 1.0, "duration": 0.1}],
    [{"type": "fret", "string": 6, "fret": 1}, {"type": "pluck", "string": 6, "force": 1.4},
     {"type": "hammer_on", "string": 6, "fret": 3}],
    [{"type": "release", "string": 2, "what": "bend"}],
    [{"type": "fret", "string": 5, "fret": 0}, {"type": "pluck", "string": 5, "force": 1.6},
     {"type": "mute", "string": 5, "amount": 0.6, "release": 0.2}],
]


def measure(model: str, blocks: int, every: int) -> tuple[list[float], list[float]]:
    import engine

    s = engine.Session("steel-acoustic", 44100, 256, "draft", model=model)
    with_events, without = [], []
    for k in range(blocks):
        group = GROUPS[(k // every) % len(GROUPS)] if k % every == 0 else []
        t0 = time.thread_time()
        for e in group:
            try:
                s.push(dict(e))
            except ValueError:  # a bend while the last one has not returned: refused, as live
                pass
        s.block()
        (with_events if group else without).append(time.thread_time() - t0)
    return with_events, without


def _row(model: str, kind: str, t: list[float]) -> str:
    ms = np.asarray(t) * 1e3
    return (f"| {model} | {kind} | {len(ms)} | {np.median(ms):.2f} | {np.percentile(ms, 99):.2f} "
            f"| {ms.max():.2f} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--blocks", type=int, default=4000)
    ap.add_argument("--every", type=int, default=13, help="blocks from one group to the next")
    a = ap.parse_args()
    if not 2 <= a.every < a.blocks:
        ap.error("--every must be at least 2 and less than --blocks (both kinds of block are timed)")
    import engine

    rows = []
    for model in engine.MODELS:
        measure(model, 200, a.every)  # the kernels loaded, the first calls made
        ev, plain = measure(model, a.blocks, a.every)
        rows += [_row(model, "with events", ev), _row(model, "without", plain)]
    print(f"\nCPU time of one live block's block() ({a.blocks} blocks of 256 frames at 44.1 kHz, "
          f"a group of events every {a.every} blocks)\n")
    print("| model | blocks | count | median, ms | p99, ms | longest, ms |")
    print("| --- | --- | ---: | ---: | ---: | ---: |")
    print("\n".join(rows))


if __name__ == "__main__":
    main()
