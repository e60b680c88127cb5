"""Service benchmark (not a test): latency, time to first byte and throughput over real HTTP.

    PYTHONPATH=. .venv/bin/python benchmarks/service_bench.py [--requests 60] [--workers 1 2]

Starts ``uvicorn service.app:app`` on 127.0.0.1 (a free port) once per worker count, measures,
stops it by its PID, and prints a Markdown table:

* warm latency p50/p99 of ``POST /render`` of a 1-second single note (sequential requests, after
  warm-up requests), next to the engine's own time for the same scene in this process;
* time to first byte (headers + first audio block) and total time of a 20-second ``/render/stream``;
* throughput: renders per second with 4 clients at once, of the 1 s note and of a 1 s fretted
  six-string chord (heavy enough that the workers, not HTTP, are the bottleneck).
"""

from __future__ import annotations

import argparse
import os
import platform
import signal
import socket
import statistics
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import httpx

ROOT = Path(__file__).resolve().parents[1]
NOTE_1S = {"duration": 1.0, "events": [{"type": "pluck", "time": 0.0, "string": 1, "force": 2.0}]}
NOTE_20S = {**NOTE_1S, "duration": 20.0}
# A heavier scene: a fretted six-string chord (fingers on strings make the engine oversample them).
CHORD_1S = {"duration": 1.0, "events": [
    *({"type": "fret", "time": 0.0, "string": s, "fret": f, "force": 2.0}
      for s, f in ((6, 3), (5, 2), (1, 3), (2, 3))),
    *({"type": "pluck", "time": 0.02 * i, "string": s, "force": 2.0}
      for i, s in enumerate(range(6, 0, -1))),
]}
CLIENTS = 4


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Server:
    def __init__(self, workers: int):
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        env = {**os.environ, "GUITAR_WORKERS": str(workers), "GUITAR_QUEUE_SIZE": "64",
               "GUITAR_LOG_LEVEL": "WARNING",
               "PYTHONPATH": os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))}
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "uvicorn", "service.app:app", "--host", "127.0.0.1",
             "--port", str(self.port), "--no-access-log", "--log-level", "warning"],
            cwd=ROOT, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        deadline = time.monotonic() + 180
        while time.monotonic() < deadline:
            try:
                if httpx.get(self.url + "/health", timeout=2).status_code == 200:
                    return
            except httpx.TransportError:
                pass
            if self.proc.poll() is not None:
                raise RuntimeError("uvicorn exited during start-up")
            time.sleep(0.2)
        self.stop()
        raise TimeoutError("service not ready in 180 s")

    def stop(self) -> None:
        if self.proc.poll() is None:
            os.kill(self.proc.pid, signal.SIGTERM)
            try:
                self.proc.wait(30)
            except subprocess.TimeoutExpired:
                os.kill(self.proc.pid, signal.SIGKILL)
                self.proc.wait()


def percentile(xs: list[float], q: float) -> float:
    xs = sorted(xs)
    k = (len(xs) - 1) * q
    lo, hi = int(k), min(int(k) + 1, len(xs) - 1)
    return xs[lo] + (xs[hi] - xs[lo]) * (k - lo)


def latency(url: str, n: int) -> tuple[list[float], list[float]]:
    walls, renders = [], []
    with httpx.Client(base_url=url, timeout=120) as c:
        for _ in range(3):
            c.post("/render", json=NOTE_1S).raise_for_status()
        for _ in range(n):
            t0 = time.perf_counter()
            r = c.post("/render", json=NOTE_1S)
            walls.append(time.perf_counter() - t0)
            r.raise_for_status()
            renders.append(float(r.headers["x-render-seconds"]))
    return walls, renders


def stream_ttfb(url: str, repeats: int = 5) -> tuple[list[float], list[float]]:
    firsts, totals = [], []
    with httpx.Client(base_url=url, timeout=300) as c:
        for _ in range(repeats):
            t0 = time.perf_counter()
            with c.stream("POST", "/render/stream", json=NOTE_20S) as r:
                r.raise_for_status()
                it = r.iter_raw()
                next(it)  # the WAV header and the first block
                firsts.append(time.perf_counter() - t0)
                for _ in it:
                    pass
            totals.append(time.perf_counter() - t0)
    return firsts, totals


def throughput(url: str, n: int, scene: dict) -> float:
    def one(_: int) -> None:
        httpx.post(url + "/render", json=scene, timeout=300).raise_for_status()

    with ThreadPoolExecutor(CLIENTS) as ex:
        list(ex.map(one, range(CLIENTS)))  # warm every worker
        t0 = time.perf_counter()
        list(ex.map(one, range(n)))
    return n / (time.perf_counter() - t0)


def engine_alone(scene: dict, n: int) -> list[float]:
    import engine

    engine.render(scene)
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        engine.render(scene)
        times.append(time.perf_counter() - t0)
    return times


def _spin(n: int) -> float:
    t0 = time.perf_counter()
    s = 0
    for i in range(n):
        s += i * i
    return time.perf_counter() - t0


def parallel_speedup(n: int = 5_000_000) -> float:
    """How much faster two processes get through two equal CPU-bound jobs than one process does:
    2.0 on two real cores; about 1.0 where the 'cores' share one (SMT siblings, CPU quota)."""
    import multiprocessing as mp

    solo = _spin(n)
    with mp.get_context("spawn").Pool(2) as p:
        p.map(_spin, [1000, 1000])  # started
        t0 = time.perf_counter()
        p.map(_spin, [n, n])
        pair = time.perf_counter() - t0
    return 2 * solo / pair


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--requests", type=int, default=60)
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    args = ap.parse_args()
    ms = 1000.0

    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python "
          f"{platform.python_version()}; scene: 1 s (and 20 s) single pluck, string 1, 44.1 kHz, "
          "WAV PCM_16; loopback HTTP\n")
    speedup = parallel_speedup()
    eng = engine_alone(NOTE_1S, args.requests)
    chord = engine_alone(CHORD_1S, 10)
    rows = []
    for w in args.workers:
        server = Server(w)
        try:
            walls, renders = latency(server.url, args.requests)
            firsts, totals = stream_ttfb(server.url)
            rps = throughput(server.url, args.requests, NOTE_1S)
            chord_rps = throughput(server.url, args.requests // 2, CHORD_1S)
        finally:
            server.stop()
        rows.append((w, walls, renders, firsts, totals, rps, chord_rps))

    print("| workers | /render p50 | /render p99 | of which X-Render-Seconds p50 "
          "| stream 20 s: first byte p50 | stream 20 s: total p50 "
          f"| throughput, note ({CLIENTS} clients) | throughput, chord ({CLIENTS} clients) |")
    print("|---|---|---|---|---|---|---|---|")
    for w, walls, renders, firsts, totals, rps, chord_rps in rows:
        print(f"| {w} | {percentile(walls, .5) * ms:.1f} ms | {percentile(walls, .99) * ms:.1f} ms "
              f"| {statistics.median(renders) * ms:.1f} ms "
              f"| {statistics.median(firsts) * ms:.1f} ms | {statistics.median(totals):.2f} s "
              f"| {rps:.1f} renders/s | {chord_rps:.1f} renders/s |")
    print(f"\nengine.render in this process, 1 s note: p50 {percentile(eng, .5) * ms:.1f} ms, "
          f"p99 {percentile(eng, .99) * ms:.1f} ms; 1 s chord: p50 "
          f"{percentile(chord, .5) * ms:.1f} ms ({args.requests} and 10 runs). A 1 s render is "
          "1 s of audio, so renders/s is also seconds of audio per second.")
    print(f"CPU parallelism of this machine: two processes do {speedup:.2f}x the work of one "
          "(2.0 = two independent cores); worker throughput cannot scale beyond it.")


if __name__ == "__main__":
    main()
