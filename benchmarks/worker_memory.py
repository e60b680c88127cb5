"""A render worker's memory over repeated passes of the work the service gives it: does it grow
with the requests it serves, or only with what it loads once?

One process does what a render worker does (``service.worker.warm_up``, then the engine calls of
its jobs), pass after pass, each pass the mixed load's kinds of work (``benchmarks.mixed_load``):
small renders, a maximal scene (six fretted strings, 96 kHz, ``high``), each corpus song imported
and rendered at 96 kHz ``high`` (its first ``--song-seconds``), the same song at the default rate
as a job renders it, and its JAMS labels; after each job, what the worker does after each job
(``service.worker._give_back_memory``: glibc's ``malloc_trim``), timed, unless ``--no-trim``.
Printed: the RSS after the warm-up and after each pass, and the trim's time per job.  A leak grows
every pass; what a first use loads (a preset's calibrations, an importer's modules) shows in the
first pass only.

    python -m benchmarks.worker_memory [--passes 4] [--song-seconds 1.5] [--no-trim]
"""

from __future__ import annotations

import argparse
import gc
import io
import time
from pathlib import Path

import engine
from benchmarks.load import maximal_scene, small_scene
from benchmarks.mixed_load import CORPUS, SONGS
from service.worker import _give_back_memory, warm_up


def rss_mib() -> float:
    for line in Path("/proc/self/status").read_text().splitlines():
        if line.startswith("VmRSS:"):
            return int(line.split()[1]) / 1024
    raise RuntimeError("no VmRSS in /proc/self/status")


def song_scene(name: str, data: bytes, **options) -> dict:
    source = io.BytesIO(data)
    source.name = name
    return dict(engine.score_to_scene(source, **options))


def one_pass(songs: list[tuple[str, bytes]], song_seconds: float, trim: bool) -> list[float]:
    """The pass's jobs; the seconds each job's trim took."""
    trims: list[float] = []

    def job_done() -> None:
        if trim:
            t0 = time.perf_counter()
            _give_back_memory()
            trims.append(time.perf_counter() - t0)

    for i in range(20):
        engine.render_result(small_scene(i))
        job_done()
    engine.render_result(maximal_scene(1.0))
    job_done()
    for name, data in songs:
        heavy = song_scene(name, data, all_instruments=True, sample_rate=96000,
                           max_seconds=song_seconds)
        engine.render_result({**heavy, "quality": "high"})
        job_done()
        job = song_scene(name, data, all_instruments=True, max_seconds=2 * song_seconds)
        engine.render_result(job)
        job_done()
        engine.scene_labels(job).dumps()
        job_done()
    return trims


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--passes", type=int, default=4)
    ap.add_argument("--song-seconds", type=float, default=1.5)
    ap.add_argument("--no-trim", action="store_true",
                    help="leave glibc's heaps as they are after each job")
    a = ap.parse_args()
    songs = [(rel, (CORPUS / rel).read_bytes()) for rel in SONGS if (CORPUS / rel).exists()]
    if not songs:
        raise SystemExit(f"no corpus songs in {CORPUS} (make install fetches them)")
    t0 = time.perf_counter()
    warm_up(engine)
    rows = [("after the warm-up", rss_mib(), time.perf_counter() - t0)]
    trims: list[float] = []
    for k in range(a.passes):
        t0 = time.perf_counter()
        trims += one_pass(songs, a.song_seconds, not a.no_trim)
        gc.collect()
        rows.append((f"after pass {k + 1}", rss_mib(), time.perf_counter() - t0))
    print(f"render worker's RSS; a pass: 21 renders, then {len(songs)} songs "
          f"({', '.join(Path(n).name for n, _ in songs)}) each rendered twice and labelled")
    print(f"{'':20s} | {'RSS MiB':>8s} | {'change':>7s} | {'seconds':>7s}")
    for i, (label, mib, secs) in enumerate(rows):
        change = f"{mib - rows[i - 1][1]:+7.1f}" if i else ""
        print(f"{label:20s} | {mib:8.1f} | {change:>7s} | {secs:7.1f}")
    if trims:
        mean = 1e3 * sum(trims) / len(trims)
        print(f"malloc_trim after each of {len(trims)} jobs: mean {mean:.2f} ms, "
              f"longest {1e3 * max(trims):.2f} ms")
    else:
        print("no trim after the jobs (--no-trim, or not glibc)")


if __name__ == "__main__":
    main()
