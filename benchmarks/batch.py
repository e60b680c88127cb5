"""Batch throughput on Dask: audio seconds per wall second with 1 and 2 workers, the per-item
overhead of Dask against rendering the same items in one process, and a projection of a
26,000-song corpus on N workers from the measured costs.

    python -m benchmarks.batch                 # 12 items of 8 s, quality standard: a few minutes
    python -m benchmarks.batch --items 24 --seconds 20 --quality high

Every item is rendered by ``cli.batch.render_item`` (render, write audio and JAMS labels, rename),
so the in-process column and the Dask columns do the same work; workers are warmed up
(``engine.warmup``) before the clock starts.  The projection assumes the corpus' songs render at
the measured cost per audio second (the items' quality and content) and that N workers scale as
the measured 1 -> 2 worker step did (or, in the other column, perfectly: a core per worker),
which for more workers than this machine has cores is an assumption, not a measurement.
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

CORPUS_SONGS = 26_000
CORPUS_HOURS = 4_000.0  # DadaGP-sized: about 4,000 hours of audio (issue 23)


def _items(n: int, seconds: float, quality: str):
    from cli import batch, dataset

    spec = dataset.Spec(name="bench", seed=11, count=n, duration=(seconds, seconds),
                        presets=["steel-acoustic", "nylon-classical", "electric"],
                        qualities=[quality])
    return [batch.Item(id=f"bench-{i:04d}", input=f"bench#{i}", kind="drawn",
                       scene=dataset.draw_scene(spec, i), seed=spec.seed, duration=seconds)
            for i in range(n)]


def in_process(items, out: Path, options: dict) -> tuple[float, float]:
    """(wall time, sum of the engine times) of the items rendered one after another here."""
    from cli import batch

    batch._warm()
    t0 = time.perf_counter()
    engine_s = 0.0
    for it in items:
        row = batch.render_item(it, str(out), options)
        assert row["status"] == "done", row
        engine_s += row["render_seconds"]
    return time.perf_counter() - t0, engine_s


def timed_item(item, out_dir: str, options: dict) -> tuple[dict, float]:
    """``render_item`` and its wall time inside the worker (what Dask adds is outside it)."""
    from cli import batch

    t = time.perf_counter()
    row = batch.render_item(item, out_dir, options)
    return row, time.perf_counter() - t


def on_dask(items, out: Path, options: dict, workers: int) -> tuple[float, float, float]:
    """(wall time, sum of the items' times inside the workers, sum of their engine times)."""
    from dask.distributed import Client, LocalCluster, wait

    from cli import batch

    with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                      host="127.0.0.1", dashboard_address=None) as cluster, \
            Client(cluster) as client:
        client.run(batch._warm)  # every worker loads its kernels before the clock starts
        t0 = time.perf_counter()
        futures = [client.submit(timed_item, it, str(out), options, pure=False) for it in items]
        wait(futures)
        wall = time.perf_counter() - t0
        results = client.gather(futures)
    rows = [r for r, _ in results]
    assert all(r["status"] == "done" for r in rows), [r for r in rows if r["status"] != "done"]
    return wall, sum(t for _, t in results), sum(r["render_seconds"] for r in rows)


def _fmt_duration(s: float) -> str:
    if s >= 86400:
        return f"{s / 86400:.1f} d"
    if s >= 3600:
        return f"{s / 3600:.1f} h"
    return f"{s / 60:.0f} min"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--items", type=int, default=12)
    ap.add_argument("--seconds", type=float, default=8.0, help="audio seconds per item")
    ap.add_argument("--quality", default="standard", choices=("draft", "standard", "high"))
    args = ap.parse_args(argv)
    import logging

    logging.getLogger("distributed").setLevel(logging.ERROR)
    items = _items(args.items, args.seconds, args.quality)
    audio_s = args.items * args.seconds
    options = {"format": "wav", "labels": True}
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp)
        for sub in ("audio", "labels"):
            (out / sub).mkdir()
        # one process before and after the Dask runs: the machine's drift shows between them
        p1, p1_engine = in_process(items, out, options)
        d1, d1_items, d1_engine = on_dask(items, out, options, 1)
        d2, d2_items, d2_engine = on_dask(items, out, options, 2)
        p2, p2_engine = in_process(items, out, options)
    one_wall = min(p1, p2)
    mean_item = one_wall / args.items
    overhead = (d1 - d1_items) / args.items  # what Dask adds around each item on one worker
    cost_per_audio_s = one_wall / audio_s
    scaling = (d1 / d2) / 2  # parallel efficiency of the 1 -> 2 worker step
    print(f"batch benchmark: {args.items} items of {args.seconds:g} s audio, quality "
          f"{args.quality}, {cores} cores on this machine")
    print()
    print("| run | wall s | audio s / wall s | items' own time s | of which engine s |")
    print("| --- | ---: | ---: | ---: | ---: |")
    print(f"| one process, no Dask (before) | {p1:.2f} | {audio_s / p1:.1f} | {p1:.2f} | "
          f"{p1_engine:.2f} |")
    print(f"| Dask, 1 worker | {d1:.2f} | {audio_s / d1:.1f} | {d1_items:.2f} | "
          f"{d1_engine:.2f} |")
    print(f"| Dask, 2 workers | {d2:.2f} | {audio_s / d2:.1f} | {d2_items:.2f} | "
          f"{d2_engine:.2f} |")
    print(f"| one process, no Dask (after) | {p2:.2f} | {audio_s / p2:.1f} | {p2:.2f} | "
          f"{p2_engine:.2f} |")
    print()
    print(f"Dask's own overhead per item (1 worker: wall minus the items' own time): "
          f"{overhead * 1000:.0f} ms, {100 * overhead / mean_item:.2f} % of an item of "
          f"{args.seconds:g} s ({mean_item:.2f} s in one process)")
    print(f"1 worker against one process: {d1 / one_wall:.2f}x the wall time (the items' own "
          f"time {d1_items / one_wall:.2f}x: the render itself runs slower or faster on the "
          "worker, e.g. under other load)")
    print(f"1 -> 2 workers: {d1 / d2:.2f}x ({100 * scaling:.0f} % parallel efficiency)")
    song_s = CORPUS_HOURS * 3600 / CORPUS_SONGS
    per_song = song_s * cost_per_audio_s + max(overhead, 0.0)
    print()
    print(f"Projection: {CORPUS_SONGS} songs, {CORPUS_HOURS:g} h of audio (mean song "
          f"{song_s / 60:.1f} min), whole songs as items, at the measured "
          f"{cost_per_audio_s:.4f} s per audio second (the faster one-process run) plus Dask's "
          f"overhead per item: {per_song:.1f} s per song, overhead "
          f"{100 * max(overhead, 0) / per_song:.3f} % of it. 'dedicated' assumes each worker has "
          "a core of its own; 'as measured here' scales by this machine's 1 -> 2 worker "
          f"efficiency ({100 * scaling:.0f} %), whose two cores are shared:")
    print()
    print("| workers | corpus wall time, dedicated | as measured here |")
    print("| ---: | ---: | ---: |")
    for n in (1, 2, 8, 32, 128, 512):
        ideal = CORPUS_SONGS * per_song / n
        here = ideal if n == 1 else ideal / scaling
        print(f"| {n} | {_fmt_duration(ideal)} | {_fmt_duration(here)} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
