"""How long a full collection of Python's garbage collector stops the API process and the workers,
with what the process holds at startup in the collector's sight and frozen out of it
(``gc.freeze``, as the app's lifespan does once it has started, and a worker after its
warm-up).

One process imports the app (``service.app``: FastAPI, the routes, the engine and its schemas)
and runs its lifespan as uvicorn does (its workers start beside it), then times full collections
(``gc.collect()``, the median and the longest of ``--rounds``) before and after ``gc.freeze()``.
Each such collection runs on the event loop and stops every request and live block for its
length; ``guitar_gc_pause_seconds`` counts those of a running server.  A second process warms up
as a live worker does (``service.live_worker.warm_up``: the kernels, the default guitar on both
models at two rates) and is timed the same way: there a collection runs on the audio thread,
whose blocks are due 20 ms ahead of when they play.  A third warms up as a render worker does
(``service.worker.warm_up``: the kernels, the audio codecs, the labels' libraries), where a
collection stops the render under way.

    python -m benchmarks.gc_pause [--rounds 9]
"""

from __future__ import annotations

import argparse
import asyncio
import gc
import multiprocessing as mp
import os
import statistics
import tempfile
import time


def collections(rounds: int) -> tuple[float, float]:
    times = []
    for _ in range(rounds):
        t0 = time.perf_counter()
        gc.collect()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), max(times)


async def measure(rounds: int) -> list[tuple[str, int, float, float]]:
    from service.app import create_app

    app = create_app()
    rows = []
    async with app.router.lifespan_context(app):
        gc.unfreeze()  # the lifespan froze what it holds: first, as without it
        rows.append(("everything in sight", len(gc.get_objects()), *collections(rounds)))
        gc.freeze()
        rows.append(("after gc.freeze()", len(gc.get_objects()), *collections(rounds)))
    return rows


def warmed_worker(kind: str, rounds: int, out) -> None:
    """In a process of its own: a live worker's or a render worker's warm-up, then the same rows."""
    import engine
    from service import live_worker, worker

    (live_worker if kind == "live" else worker).warm_up(engine)
    rows = [("everything in sight", len(gc.get_objects()), *collections(rounds))]
    gc.freeze()
    rows.append(("after gc.freeze()", len(gc.get_objects()), *collections(rounds)))
    out.put(rows)


def _table(title: str, rows: list) -> None:
    print(f"\n{title}\n")
    print("| objects the collector tracks | count | median pause, ms | longest, ms |")
    print("| --- | ---: | ---: | ---: |")
    for name, n, med, most in rows:
        print(f"| {name} | {n} | {med * 1e3:.1f} | {most * 1e3:.1f} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=9)
    a = ap.parse_args()
    with tempfile.TemporaryDirectory(prefix="gc-pause-") as tmp:
        os.environ.setdefault("GUITAR_DATA_DIR", tmp)
        os.environ.setdefault("GUITAR_WORKERS", "1")
        os.environ.setdefault("GUITAR_LIVE_WORKERS", "0")
        rows = asyncio.run(measure(a.rounds))
    ctx = mp.get_context("spawn")
    warmed = {}
    for kind in ("live", "render"):
        out = ctx.Queue()
        proc = ctx.Process(target=warmed_worker, args=(kind, a.rounds, out))
        proc.start()
        warmed[kind] = out.get(timeout=600)
        proc.join()
    _table(f"Full collections of the API process's heap after startup ({a.rounds} rounds)", rows)
    _table(f"Full collections of a live worker's heap after its warm-up ({a.rounds} rounds)",
           warmed["live"])
    _table(f"Full collections of a render worker's heap after its warm-up ({a.rounds} rounds)",
           warmed["render"])


if __name__ == "__main__":
    main()
