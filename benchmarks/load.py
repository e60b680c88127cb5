"""Load test of the HTTP service: a real ``uvicorn service.app:app`` on 127.0.0.1 and 256 clients.

The clients (asyncio tasks sharing one httpx connection pool; httpx rather than locust: it is
already the project's HTTP client for tests, needs no second process tree, and 256 asyncio tasks
are cheap on a 2-core machine) mix, by weight:

* small renders (``/render``, a short pluck or chord), whose latency is the figure that matters;
* small streams read to the end;
* streams and renders abandoned by the client: before the first byte, or after the first bytes;
* maximal renders: the longest scene the server admits at 96 kHz, quality ``high``, six fingered
  strings (the duration the server's cost budget allows, read from its own 422).

A client that gets a 503 waits for its Retry-After (at most 2 s) and goes on.  Then a second
phase measures fairness: two maximal renders sent together while one client renders small scenes
one after the other, until both maximal renders are answered.

Printed: status counts of each phase (anything but 200, 4xx and 503 with Retry-After is counted
as ``unexpected``), p50/p99 of the small renders, and the resident memory (RSS) of the server and
of each worker process before and after.

    python -m benchmarks.load [--clients 256] [--seconds 60] [--workers 2]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import random
import signal
import socket
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path

import httpx

ROOT = Path(__file__).resolve().parents[1]


def small_scene(i: int) -> dict:
    return {"duration": 0.2, "events": [
        {"type": "pluck", "time": 0.0, "string": 1 + i % 6, "force": 1.0 + (i % 7) * 0.3}]}


def maximal_scene(duration: float) -> dict:
    frets = [{"type": "fret", "time": 0.0, "string": s, "fret": 5, "force": 2.0}
             for s in range(1, 7)]
    plucks = [{"type": "pluck", "time": 0.01 * i, "string": s, "force": 2.0}
              for i, s in enumerate(range(6, 0, -1))]
    return {"duration": duration, "sample_rate": 96000, "quality": "high",
            "events": frets + plucks}


# ---- processes and memory --------------------------------------------------------------------

def _rss_kib(pid: int) -> int:
    try:
        for line in Path(f"/proc/{pid}/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    except OSError:
        pass
    return 0


def _children(pid: int) -> list[int]:
    out = []
    for d in Path("/proc").iterdir():
        if d.name.isdigit():
            try:
                stat = (d / "stat").read_text()
            except OSError:
                continue
            if int(stat.rsplit(")", 1)[1].split()[1]) == pid:
                out.append(int(d.name))
    return out


def memory(pid: int) -> dict[str, int]:
    """RSS in MiB of the server and of every process below it (workers, the spawn tracker)."""
    out = {f"server {pid}": _rss_kib(pid) // 1024}
    stack = _children(pid)
    while stack:
        c = stack.pop()
        try:
            cmd = Path(f"/proc/{c}/cmdline").read_bytes().decode(errors="replace")
        except OSError:
            continue
        kind = ("tracker" if "resource_tracker" in cmd else
                "worker" if "spawn_main" in cmd else "child")
        out[f"{kind} {c}"] = _rss_kib(c) // 1024
        stack += _children(c)
    return out


def start_server(workers: int, extra_env: dict[str, str]) -> tuple[subprocess.Popen, str]:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    env = {**os.environ, "GUITAR_WORKERS": str(workers), "GUITAR_LOG_LEVEL": "WARNING",
           "PYTHONPATH": os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH"))
                                         if p), **extra_env}
    proc = subprocess.Popen([sys.executable, "-m", "uvicorn", "service.app:app", "--host",
                             "127.0.0.1", "--port", str(port), "--no-access-log",
                             "--log-level", "warning", "--limit-concurrency", "1000"],
                            cwd=ROOT, env=env, stdout=subprocess.DEVNULL)
    url = f"http://127.0.0.1:{port}"
    deadline = time.monotonic() + 180
    while time.monotonic() < deadline:
        try:
            if httpx.get(url + "/health/ready", timeout=2).status_code == 200:
                return proc, url
        except httpx.TransportError:
            pass
        if proc.poll() is not None:
            raise RuntimeError("uvicorn exited")
        time.sleep(0.2)
    raise TimeoutError("server not ready")


# ---- the clients ------------------------------------------------------------------------------

class Stats:
    def __init__(self) -> None:
        self.status: Counter[str] = Counter()
        self.small_s: list[float] = []
        self.small_server_s: list[float] = []  # the same renders' Server-Timing
        self.unexpected: list[str] = []

    def record(self, kind: str, r: httpx.Response | None, error: str | None = None) -> None:
        if error is not None:
            self.status[f"{kind}: {error}"] += 1
            if not error.startswith("left"):
                self.unexpected.append(f"{kind}: {error}")
            return
        assert r is not None
        code = r.status_code
        ok = code == 200 or 400 <= code < 500 or (code == 503 and "retry-after" in r.headers)
        self.status[f"{kind}: {code}"] += 1
        if not ok:
            self.unexpected.append(f"{kind}: {code} {r.text[:200]}")


def server_seconds(r: httpx.Response) -> float | None:
    """The server's own time for a request, from its ``Server-Timing: app;dur=MS`` header."""
    for part in r.headers.get("server-timing", "").split(";"):
        if part.strip().startswith("dur="):
            return float(part.strip()[4:]) / 1000
    return None


async def _retry_pause(r: httpx.Response) -> None:
    if r.status_code == 503:
        await asyncio.sleep(min(float(r.headers.get("retry-after", 1)), 2.0) * random.random())


async def small_render(c: httpx.AsyncClient, st: Stats, i: int) -> None:
    t0 = time.perf_counter()
    r = await c.post("/render", json=small_scene(i))
    if r.status_code == 200:
        st.small_s.append(time.perf_counter() - t0)
        server = server_seconds(r)
        if server is not None:
            st.small_server_s.append(server)
    st.record("small render", r)
    await _retry_pause(r)


async def small_stream(c: httpx.AsyncClient, st: Stats, i: int) -> None:
    async with c.stream("POST", "/render/stream", json=small_scene(i)) as r:
        await r.aread()
    st.record("small stream", r)
    await _retry_pause(r)


async def abandoned(c: httpx.AsyncClient, st: Stats, i: int, path: str, before: bool) -> None:
    """A request whose client leaves: before the first byte or after the first bytes.  Leaving
    before is a request on a socket of its own, closed after a random wait (as a client that goes
    away closes its socket): cancelling a request inside ``c``'s pool could leave a connection
    there that no later request got back (httpx's PoolTimeout, minutes later)."""
    kind = f"{'stream' if 'stream' in path else 'render'} left " + ("early" if before else "late")
    scene = maximal_scene(2.0) if i % 2 else small_scene(i)
    if not before:
        async with c.stream("POST", path, json=scene) as r:
            async for _ in r.aiter_raw():
                break  # the first bytes, then gone (the response closes its connection)
        st.record(kind, r)
        return
    body = json.dumps(scene).encode()
    url = c.base_url
    reader, writer = await asyncio.open_connection(url.host, url.port)
    try:
        writer.write(f"POST {path} HTTP/1.1\r\nHost: {url.host}:{url.port}\r\n"
                     "Content-Type: application/json\r\n"
                     f"Content-Length: {len(body)}\r\nConnection: close\r\n\r\n".encode() + body)
        await writer.drain()
        try:
            first = await asyncio.wait_for(reader.readline(), 0.05 + random.random() * 0.3)
            st.status[f"{kind}: answered first" if first else f"{kind}: closed by the server"] += 1
        except TimeoutError:
            st.record(kind, None, "left")
    finally:
        writer.close()


async def maximal_render(c: httpx.AsyncClient, st: Stats, duration: float) -> None:
    r = await c.post("/render", json=maximal_scene(duration), timeout=600)
    st.record("maximal render", r)
    await _retry_pause(r)


async def client(c: httpx.AsyncClient, st: Stats, n: int, until: float, maximal_s: float) -> None:
    rng = random.Random(n)
    i = n * 100_000
    while time.monotonic() < until:
        i += 1
        x = rng.random()
        try:
            if x < 0.55:
                await small_render(c, st, i)
            elif x < 0.70:
                await small_stream(c, st, i)
            elif x < 0.77:
                await abandoned(c, st, i, "/render/stream", before=True)
            elif x < 0.84:
                await abandoned(c, st, i, "/render/stream", before=False)
            elif x < 0.91:
                await abandoned(c, st, i, "/render", before=True)
            else:
                await maximal_render(c, st, maximal_s)
        except httpx.HTTPError as exc:
            st.record(f"transport ({x:.2f})", None, type(exc).__name__)


async def mixed(url: str, clients: int, seconds: float, maximal_s: float) -> Stats:
    st = Stats()
    # Idle connections are dropped by the client after 2 s, before uvicorn's 5 s keep-alive
    # timeout closes them from its side: a request sent on a connection the server is closing
    # at that moment would fail with a read error that says nothing about the service.
    limits = httpx.Limits(max_connections=clients, max_keepalive_connections=clients,
                          keepalive_expiry=2.0)
    async with httpx.AsyncClient(base_url=url, timeout=120, limits=limits) as c:
        until = time.monotonic() + seconds
        await asyncio.gather(*(client(c, st, n, until, maximal_s) for n in range(clients)))
    return st


async def fairness(url: str, maximal_s: float) -> tuple[Stats, float]:
    st = Stats()
    async with httpx.AsyncClient(base_url=url, timeout=600) as c:
        t0 = time.monotonic()
        heavy = [asyncio.ensure_future(maximal_render(c, st, maximal_s)) for _ in range(2)]
        i = 0
        while not all(h.done() for h in heavy):
            i += 1
            await small_render(c, st, i)
        await asyncio.gather(*heavy)
    return st, time.monotonic() - t0


def _pct(xs: list[float], p: float) -> float:
    xs = sorted(xs)
    return xs[min(len(xs) - 1, int(round(p / 100 * (len(xs) - 1))))] if xs else float("nan")


def report(name: str, st: Stats) -> None:
    print(f"\n{name}")
    for key, n in sorted(st.status.items()):
        print(f"  {key:34} {n:7d}")
    xs = st.small_s
    print(f"  small renders answered 200: {len(xs)}; latency p50 {_pct(xs, 50) * 1000:.0f} ms, "
          f"p99 {_pct(xs, 99) * 1000:.0f} ms, max {max(xs, default=float('nan')) * 1000:.0f} ms")
    print(f"  unexpected (not 200, 4xx or 503 with Retry-After): {len(st.unexpected)}")
    for u in st.unexpected[:5]:
        print(f"    {u}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clients", type=int, default=256)
    ap.add_argument("--seconds", type=float, default=60.0, help="length of the mixed phase")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--no-fairness", action="store_true", help="skip the two-maximal phase")
    ap.add_argument("--no-mixed", action="store_true", help="skip the mixed phase")
    ap.add_argument("--heavy-workers", type=int, default=None,
                    help="GUITAR_HEAVY_WORKERS of the server (= --workers: no worker reserved "
                         "for small renders, to compare)")
    args = ap.parse_args()
    env = {} if args.heavy_workers is None else {"GUITAR_HEAVY_WORKERS": str(args.heavy_workers)}
    proc, url = start_server(args.workers, env)
    try:
        limits = httpx.get(url + "/limits").json()
        probe = httpx.post(url + "/render", json=maximal_scene(limits["max_duration_s"]))
        maximal_s = (probe.json()["detail"][0]["ctx"]["le"] * 0.98 if probe.status_code == 422
                     else limits["max_duration_s"])
        print(f"server {url} (pid {proc.pid}), {args.workers} workers, heavy renders on "
              f"{args.heavy_workers or max(1, args.workers - 1)}; {args.clients} clients for "
              f"{args.seconds:g} s; maximal render: {maximal_s:.2f} s of audio at 96 kHz, high, "
              f"six fingered strings (the server's budget GUITAR_MAX_RENDER_S "
              f"{limits['max_render_s']:g} s of estimated work)")
        before = memory(proc.pid)
        if not args.no_mixed:
            t0 = time.monotonic()
            st = asyncio.run(mixed(url, args.clients, args.seconds, maximal_s))
            wall = time.monotonic() - t0
            report(f"mixed load ({wall:.0f} s, including the wait for the last answers)", st)
            # let abandoned and queued work drain before the next phase
            deadline = time.monotonic() + 120
            while time.monotonic() < deadline:
                pool = httpx.get(url + "/health").json()["pool"]
                if pool["in_flight"] == 0 and pool["workers_ready"] == args.workers:
                    break
                time.sleep(0.5)
            print(f"  drained: pool {pool}")
        if not args.no_fairness:
            fst, took = asyncio.run(fairness(url, maximal_s))
            report(f"two maximal renders sent together, one client rendering small scenes "
                   f"meanwhile ({took:.0f} s)", fst)
        after = memory(proc.pid)
        health = httpx.get(url + "/health").json()
        print(f"\nRSS, MiB          before   after   (workers replaced during the run: "
              f"{health['pool']['replaced']}, hung: {health['pool']['hung']})")
        for key in sorted(set(before) | set(after)):
            b = before.get(key)
            a = after.get(key)
            print(f"  {key:16} {b if b is not None else '-':>6}  {a if a is not None else '-':>6}")
    finally:
        os.kill(proc.pid, signal.SIGTERM)
        try:
            proc.wait(30)
        except subprocess.TimeoutExpired:
            os.kill(proc.pid, signal.SIGKILL)


if __name__ == "__main__":
    main()
