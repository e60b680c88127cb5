"""Live play benchmark (not a test): WS /live over loopback, against a real uvicorn process.

    PYTHONPATH=. .venv/bin/python benchmarks/live.py [--dense-seconds 60] [--quick]

Starts ``uvicorn service.app:app`` on 127.0.0.1 (a free port; one render worker, one live worker
process, so every session below runs on one core), measures, stops it by its PID, and prints a
Markdown table.  The client and the server run at niceness ``--nice`` (default -10, when this
process may set it): an audio path runs ahead of other load (audio servers raise their priority;
the server's ``GUITAR_LIVE_NICE`` does it for its live workers, the browser for its audio thread).
On a machine busy with other work, at the default priority the blocks wait for the CPU behind it.

* latency: from an event sent to the arrival of the block holding the first sample of its sound (the
  frame the server's ``ack`` names: where the pluck's force starts), p50 and p99 over single plucks
  sent at random moments, at 128- and 256-frame blocks;
* underruns in a six-string session played densely for ``--dense-seconds`` (fretted notes, plucks,
  strums, hammer-ons, slides, bends, mutes: about 13 events a second, every string sounding),
  counted as the demo page's player counts them: it starts playing ``jitter`` after a block
  arrives (``--jitter-ms``, default 40 ms: the server's 20 ms lead plus 20 ms of jitter buffer),
  needs the blocks at the audio rate from then on, and a block arriving later than needed is an
  underrun, after which it starts again ``jitter`` after that block;
* the live worker's CPU time (``/proc``) per second of the dense session's audio: what one session
  costs a core, whatever else the machine runs (the late blocks above depend on that);
* sessions per core: 1, 2, 3, ... concurrent sessions, each played like the dense one, for
  ``--step-seconds`` each, until one of them has a late block; the largest count without one.

The default run takes three to five minutes.  The machine's other load shows in these figures.
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import platform
import random
import signal
import socket
import struct
import subprocess
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import httpx
import numpy as np
import websockets

ROOT = Path(__file__).resolve().parents[1]
HEADER = struct.Struct("<Q")


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Server:
    def __init__(self, max_sessions: int, nice: int):
        self.port = free_port()
        self.url = f"127.0.0.1:{self.port}"
        env = {**os.environ, "PYTHONPATH": str(ROOT), "GUITAR_WORKERS": "1",
               "GUITAR_LIVE_WORKERS": "1", "GUITAR_MAX_LIVE_SESSIONS": str(max_sessions),
               "GUITAR_LOG_LEVEL": "WARNING", "GUITAR_LIVE_NICE": str(nice),
               "GUITAR_LIVE_PRESTART": "1"}
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "uvicorn", "service.app:app", "--host", "127.0.0.1", "--port",
             str(self.port), "--no-access-log"], cwd=ROOT, env=env,
            stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        deadline = time.monotonic() + 300
        while time.monotonic() < deadline:
            try:
                if httpx.get(f"http://{self.url}/live/status", timeout=2).json()["ready"]:
                    return
            except (httpx.HTTPError, ValueError, KeyError):
                pass
            if self.proc.poll() is not None:
                raise RuntimeError("uvicorn exited")
            time.sleep(0.5)
        self.stop()
        raise TimeoutError("the live worker did not become ready")

    def cpu_seconds(self) -> float:
        """CPU time (user + system) the live worker process has used so far."""
        pid = httpx.get(f"http://{self.url}/live/status", timeout=5).json()["pids"][0]
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")

    def stop(self) -> None:
        if self.proc.poll() is None:
            os.kill(self.proc.pid, signal.SIGTERM)
            try:
                self.proc.wait(20)
            except subprocess.TimeoutExpired:
                os.kill(self.proc.pid, signal.SIGKILL)
                self.proc.wait(5)


def pct(xs: list[float], q: float) -> float:
    return float(np.percentile(np.asarray(xs), q)) if xs else float("nan")


@dataclass
class Run:
    """One session's client side: what was sent, what arrived, and when."""

    block_frames: int
    jitter_s: float
    sent: dict[str, float] = field(default_factory=dict)  # id -> time sent
    acked: dict[str, int] = field(default_factory=dict)  # id -> frame it acts at
    latencies: list[float] = field(default_factory=list)
    blocks: int = 0
    late: int = 0  # underruns: blocks that arrived after the player needed them
    worst_late_s: float = 0.0
    anchor: tuple[float, int] | None = None  # (time, frame) the player's clock runs from
    errors: list[str] = field(default_factory=list)
    rate: int = 44100

    def on_block(self, frame: int, now: float) -> None:
        # The player (as the demo page's worklet): it starts ``jitter`` after a block arrives and
        # then needs the blocks at the audio rate; a block later than that is an underrun, after
        # which it starts again ``jitter`` after that block.
        if self.anchor is None:
            self.anchor = (now + self.jitter_s, frame)
        need = self.anchor[0] + (frame - self.anchor[1]) / self.rate
        if now > need:
            self.late += 1
            self.worst_late_s = max(self.worst_late_s, now - need)
            self.anchor = (now + self.jitter_s, frame)
        self.blocks += 1
        end = frame + self.block_frames
        for ident, f in list(self.acked.items()):
            if frame <= f < end:
                self.latencies.append(now - self.sent.pop(ident))
                del self.acked[ident]


async def session(url: str, block_frames: int, seconds: float, player, jitter_s: float,
                  seed: int) -> Run:
    run = Run(block_frames, jitter_s)
    rng = random.Random(seed)
    async with websockets.connect(f"ws://{url}/live", max_queue=None) as ws:
        await ws.send(json.dumps({"type": "open", "preset": "steel-acoustic",
                                  "block_frames": block_frames}))
        opened = json.loads(await ws.recv())
        assert opened["type"] == "opened", opened
        run.rate = opened["sample_rate"]

        async def receive():
            async for m in ws:
                now = time.monotonic()
                if isinstance(m, bytes):
                    run.on_block(HEADER.unpack(m[:8])[0], now)
                else:
                    body = json.loads(m)
                    if body["type"] == "ack":
                        run.acked[body["id"]] = body["frame"]
                    elif body["type"] == "error":
                        run.errors.append(body["message"])

        task = asyncio.create_task(receive())
        t_end = time.monotonic() + seconds
        n = 0
        for delay, msgs in player(rng):
            await asyncio.sleep(delay)
            if time.monotonic() > t_end:
                break
            for m in msgs:
                n += 1
                if m.get("type") == "pluck":
                    m = {**m, "id": f"e{n}"}
                    run.sent[m["id"]] = time.monotonic()
                await ws.send(json.dumps(m))
        await asyncio.sleep(0.3)
        await ws.close()
        await task
    return run


def single_plucks(rng: random.Random):
    """A pluck now and then, at random moments (not in step with the blocks)."""
    while True:
        yield rng.uniform(0.08, 0.16), [{"type": "pluck", "string": rng.randint(1, 6),
                                         "force": 1.0}]


def dense(rng: random.Random):
    """Six strings played densely: about 13 events a second."""
    held_bend = False
    k = 0
    while True:
        k += 1
        s = rng.randint(1, 6)
        fret = rng.randint(0, 12)
        msgs = [{"type": "fret", "string": s, "fret": fret},
                {"type": "pluck", "string": s, "force": rng.uniform(0.5, 3.0),
                 "position": rng.uniform(0.6, 0.9)}]
        if k % 8 == 0:
            msgs = [{"type": "strum", "direction": rng.choice(["down", "up"]), "force": 1.5}]
        elif k % 8 == 3 and fret:
            msgs.append({"type": "hammer_on", "string": s, "fret": min(fret + 2, 20)})
        elif k % 8 == 5 and fret:
            msgs.append({"type": "slide", "string": s, "from_fret": fret,
                         "to_fret": min(fret + 3, 20), "duration": 0.1})
        elif k % 8 == 6:
            if held_bend:
                msgs.append({"type": "release", "string": 2, "what": "bend"})
            else:
                msgs += [{"type": "fret", "string": 2, "fret": 7},
                         {"type": "pluck", "string": 2},
                         {"type": "bend", "string": 2, "semitones": 1.0, "duration": 0.1}]
            held_bend = not held_bend
        elif k % 16 == 7:
            msgs.append({"type": "mute", "string": s, "amount": 0.6, "release": 0.2})
        yield rng.uniform(0.08, 0.22), msgs


async def many(url: str, n: int, seconds: float, jitter_s: float) -> list[Run]:
    return await asyncio.gather(*(session(url, 256, seconds, dense, jitter_s, seed=100 + i)
                                  for i in range(n)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--latency-seconds", type=float, default=20.0)
    ap.add_argument("--dense-seconds", type=float, default=60.0)
    ap.add_argument("--step-seconds", type=float, default=15.0)
    ap.add_argument("--max-sessions", type=int, default=8)
    ap.add_argument("--jitter-ms", type=float, default=40.0)
    ap.add_argument("--nice", type=int, default=-10,
                    help="niceness of this client and the server it starts (0: the default)")
    ap.add_argument("--quick", action="store_true", help="short runs (a smoke test)")
    a = ap.parse_args()
    if a.quick:
        a.latency_seconds, a.dense_seconds, a.step_seconds, a.max_sessions = 4, 6, 4, 2
    jitter = a.jitter_ms / 1000.0
    load0 = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    if a.nice:
        try:  # the server inherits it
            os.setpriority(os.PRIO_PROCESS, 0, a.nice)
        except OSError as exc:
            print(f"niceness {a.nice} not set ({exc}): running at the default", file=sys.stderr)
            a.nice = 0
    server = Server(a.max_sessions, a.nice)
    rows = []
    try:
        for bf in (128, 256):
            r = asyncio.run(session(server.url, bf, a.latency_seconds, single_plucks, jitter, 1))
            ms = [x * 1000 for x in r.latencies]
            rows.append((f"latency, {bf}-frame blocks ({bf / 44.1:.1f} ms)",
                         f"p50 {pct(ms, 50):.1f} ms, p99 {pct(ms, 99):.1f} ms "
                         f"({len(ms)} plucks); {r.late} underruns in {r.blocks} blocks"))
        cpu0 = server.cpu_seconds()
        r = asyncio.run(session(server.url, 256, a.dense_seconds, dense, jitter, 2))
        cpu = (server.cpu_seconds() - cpu0) / (r.blocks * 256 / 44100)
        ms = [x * 1000 for x in r.latencies]
        rows.append((f"dense six-string session, {a.dense_seconds:g} s, 256-frame blocks",
                     f"{r.late} underruns in {r.blocks} blocks (worst {r.worst_late_s * 1000:.1f} "
                     f"ms late); pluck latency p50 {pct(ms, 50):.1f} ms, p99 {pct(ms, 99):.1f} ms; "
                     f"{len(r.errors)} events refused"))
        rows.append(("live worker CPU per second of the dense session",
                     f"{cpu:.2f} s: a free core would carry {1 / cpu:.1f} such sessions"))
        best, tried = 0, []
        for n in range(1, a.max_sessions + 1):
            runs = asyncio.run(many(server.url, n, a.step_seconds, jitter))
            late = sum(x.late for x in runs)
            total = sum(x.blocks for x in runs)
            lat = [x * 1000 for r_ in runs for x in r_.latencies]
            tried.append(f"{n}: {late} underruns in {total} blocks, latency p99 "
                         f"{pct(lat, 99):.0f} ms")
            if late:
                break
            best = n
        rows.append(("concurrent dense sessions on one live worker (one core)",
                     f"{best} without an underrun ({'; '.join(tried)})"))
    finally:
        server.stop()
    load = ", ".join(f"{x:.1f}" for x in os.getloadavg())
    print(f"\nLive play over loopback ({platform.processor() or platform.machine()}, "
          f"{os.cpu_count()} CPUs, load average {load0} at the start, {load} at the end; "
          f"client jitter buffer {a.jitter_ms:g} ms; quality draft; niceness of client and "
          f"server {a.nice})\n")
    print("| measure | result |")
    print("| --- | --- |")
    for name, value in rows:
        print(f"| {name} | {value} |")


if __name__ == "__main__":
    main()
