"""Service benchmark (not a test): latency, time to first byte and throughput over real HTTP.

    PYTHONPATH=. .venv/bin/python benchmarks/service_bench.py [--requests 60] [--workers 1 2]

Starts ``uvicorn service.app:app`` on 127.0.0.1 (a free port) once per worker count, measures,
stops it by its PID, and prints a Markdown table:

* warm latency p50/p99 of ``POST /render`` of a 1-second single note (sequential requests, after
  warm-up requests), next to the engine's own time for the same scene in this process;
* time to first byte (headers + first audio block) and total time of a 20-second ``/render/stream``;
* throughput: renders per second (and seconds of audio per second) with 4 clients at once.
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


def throughput(url: str, n: int) -> float:
    def one(_: int) -> None:
        httpx.post(url + "/render", json=NOTE_1S, timeout=300).raise_for_status()

    with ThreadPoolExecutor(CLIENTS) as ex:
        list(ex.map(one, range(CLIENTS)))  # warm every worker
        t0 = time.perf_counter()
        list(ex.map(one, range(n)))
    return n / (time.perf_counter() - t0)


def engine_alone(n: int) -> list[float]:
    import engine

    engine.render(NOTE_1S)
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        engine.render(NOTE_1S)
        times.append(time.perf_counter() - t0)
    return times


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--requests", type=int, default=60)
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    args = ap.parse_args()
    ms = 1000.0

    print(f"machine: {platform.machine()}, {os.cpu_count()} cores, Python "
          f"{platform.python_version()}; scene: 1 s (and 20 s) single pluck, string 1, 44.1 kHz, "
          "WAV PCM_16; loopback HTTP\n")
    eng = engine_alone(args.requests)
    rows = []
    for w in args.workers:
        server = Server(w)
        try:
            walls, renders = latency(server.url, args.requests)
            firsts, totals = stream_ttfb(server.url)
            rps = throughput(server.url, args.requests)
        finally:
            server.stop()
        rows.append((w, walls, renders, firsts, totals, rps))

    print("| workers | /render p50 | /render p99 | of which X-Render-Seconds p50 "
          "| stream 20 s: first byte p50 | stream 20 s: total p50 "
          f"| throughput ({CLIENTS} clients) |")
    print("|---|---|---|---|---|---|---|")
    for w, walls, renders, firsts, totals, rps in rows:
        print(f"| {w} | {percentile(walls, .5) * ms:.1f} ms | {percentile(walls, .99) * ms:.1f} ms "
              f"| {statistics.median(renders) * ms:.1f} ms "
              f"| {statistics.median(firsts) * ms:.1f} ms | {statistics.median(totals):.2f} s "
              f"| {rps:.1f} renders/s = {rps:.1f} s of audio per s |")
    print(f"\nengine.render of the same 1 s scene in-process: p50 {percentile(eng, .5) * ms:.1f} ms, "
          f"p99 {percentile(eng, .99) * ms:.1f} ms ({args.requests} runs)")


if __name__ == "__main__":
    main()
