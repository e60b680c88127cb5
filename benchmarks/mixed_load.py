"""Every path of the service at once, for minutes: a real uvicorn process on 127.0.0.1 with two render
workers and one live worker, and at the same time

* HTTP clients as in ``benchmarks.load``: small renders (whose latency is the figure that matters),
  small streams read to the end, streams and renders abandoned before or after their first bytes;
* score clients uploading songs of the test corpus (``.cache/score-corpus``: Guitar Pro, MIDI,
  MusicXML) to ``POST /render/score`` at 96 kHz, quality ``high``, as long as the cost budget allows
  (read from the server's own 422 at the start): the heaviest renders the server admits;
* job clients: scene jobs (six fingered strings at 96 kHz) and score jobs (a corpus song), each
  followed to its end and its audio fetched;
* live sessions over ``WS /live`` played at a musician's rate (``benchmarks.live``'s dense player:
  about 13 events a second on six strings), in a process of their own (as a musician's computer
  would be; niceness ``--live-client-nice``), reading every block.

Live underruns are counted as ``benchmarks.live`` counts them (the demo page's player: it starts
``--jitter-ms`` after a block arrives and needs blocks at the audio rate from then on), and by the
server (``late_blocks`` of ``GET /live/status``: blocks its live worker finished after their play
time).  The same sessions first play alone for ``--baseline-seconds``: what the machine's other load
costs them, against which the mixed phase shows what other clients' work costs them.

The server runs at niceness ``--server-nice`` (default -10; its live workers inherit it) with its
render workers put back at 0 (``GUITAR_WORKER_NICE``): the API process, which relays every live
block, and the live workers run ahead of renders.  ``--server-nice 0`` runs them all at 0.  The
live worker's audio thread runs on SCHED_RR at ``--live-realtime`` (default 10,
``GUITAR_LIVE_REALTIME_PRIORITY``; 0: normal scheduling), as audio servers' threads do, and the API
process's event-loop thread, which relays the live blocks to their sockets, at ``--relay-realtime``
(default 5, ``GUITAR_RELAY_REALTIME_PRIORITY``; 0: at the server's niceness).

Printed: one table: small renders' p50/p99 as this load generator saw them and as the server
timed them (``Server-Timing``: from the request's arrival to the answer's headers; the load
generator, one Python process at the default niceness running every client, competes for the
same two cores, and its own delays are in the first figure only), live underruns (client and
server) in both phases with the machine's steal time over each (the host's time on the guest's
CPUs, which no priority inside the guest can win back: ``benchmarks.hiccups``), the API
process's event-loop lag as the server measures it (``guitar_event_loop_lag_seconds``), its
garbage collector's pauses (``guitar_gc_pause_seconds``)
and how long it took to relay each live block (``guitar_live_relay_seconds``), how long
``GET /health/live`` takes as the load generator sees it, status counts per kind (a 5xx other
than 503 with Retry-After counts as an error), jobs done, and the RSS of the server and of every
process below it before and after, with the CPU each used, and every ``--rss-every`` seconds
of the mixed load (whether a process's growth levels off).

    python -m benchmarks.mixed_load [--seconds 180] [--clients 16] [--live 2] [--server-nice 0]
                                [--rss-every 60]
"""

from __future__ import annotations

import argparse
import asyncio
import json
import os
import random
import signal
import subprocess
import sys
import tempfile
import threading
import time
from collections import Counter
from pathlib import Path

import httpx

from benchmarks.load import (
    ROOT,
    Stats,
    _pct,
    abandoned,
    maximal_scene,
    memory,
    small_render,
    small_stream,
    start_server,
)

CORPUS = ROOT / ".cache" / "score-corpus"
SONGS = ["gp/Demo v5.gp5", "gp/Chords.gp5", "midi/1390.mid", "musicxml/testTab.xml",
         "gp/Effects.gp5", "midi/test03.mid"]
HEAVY = {"sample_rate": 96000, "quality": "high", "all_instruments": True}


# ---- live sessions, in a process of their own --------------------------------------------------

async def _session(url: str, seconds: float, player, jitter_s: float, seed: int):
    """One live session as ``benchmarks.live.session`` plays it, kept when it ends early (its
    blocks so far and why it ended), with no keep-alive pings (a browser sends none)."""
    import websockets

    from benchmarks.live import HEADER, Run

    run = Run(256, jitter_s)
    run.failed = None
    rng = random.Random(seed)
    try:
        async with websockets.connect(f"ws://{url}/live", max_queue=None,
                                      ping_interval=None) as ws:
            await ws.send(json.dumps({"type": "open", "preset": "steel-acoustic",
                                      "block_frames": 256}))
            opened = json.loads(await ws.recv())
            run.rate = opened["sample_rate"]

            async def receive():
                async for m in ws:
                    if isinstance(m, bytes):
                        run.on_block(HEADER.unpack(m[:8])[0], time.monotonic())
                    elif json.loads(m)["type"] == "error":
                        run.errors.append(m)

            task = asyncio.create_task(receive())
            t_end = time.monotonic() + seconds
            for delay, msgs in player(rng):
                await asyncio.sleep(delay)
                if time.monotonic() > t_end or task.done():
                    break
                for m in msgs:
                    await ws.send(json.dumps(m))
            await ws.close()
            await task
    except Exception as exc:  # noqa: BLE001 - reported in the table
        run.failed = f"{type(exc).__name__}: {exc}"[:200]
    return run


def live_client(url: str, sessions: int, seconds: float, jitter_ms: float) -> None:
    """``sessions`` live sessions for ``seconds``, alternately dense (``benchmarks.live.dense``,
    about 13 events a second on six strings) and single plucks (one every 0.08-0.16 s); print
    one JSON line of results."""
    from benchmarks.live import dense, single_plucks

    async def all_of_them():
        return await asyncio.gather(*(
            _session(url, seconds, dense if i % 2 == 0 else single_plucks, jitter_ms / 1000,
                     200 + i) for i in range(sessions)))

    runs = asyncio.run(all_of_them())
    print(json.dumps({"blocks": sum(r.blocks for r in runs), "late": sum(r.late for r in runs),
                      "worst_late_ms": round(max(r.worst_late_s for r in runs) * 1e3, 1),
                      "refused": sum(len(r.errors) for r in runs),
                      "failed": [r.failed for r in runs if r.failed]}))


def start_live(url: str, sessions: int, seconds: float, jitter_ms: float,
               nice: int) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p)}

    def lower_niceness() -> None:  # in the child, before it runs (a musician's own computer)
        try:
            os.setpriority(os.PRIO_PROCESS, 0, nice)
        except OSError:
            pass

    return subprocess.Popen([sys.executable, "-m", "benchmarks.mixed_load", "--live-client",
                             url.removeprefix("http://"), str(sessions), str(seconds),
                             str(jitter_ms)], cwd=ROOT, env=env, stdout=subprocess.PIPE,
                            text=True, preexec_fn=lower_niceness if nice else None)


def live_result(proc: subprocess.Popen, timeout: float) -> dict:
    out, _ = proc.communicate(timeout=timeout)
    lines = [ln for ln in out.splitlines() if ln.startswith("{")]
    return json.loads(lines[-1]) if lines else {"blocks": 0, "late": 0, "failed": ["no output"]}


def cpu_seconds(pids) -> dict[int, float]:
    """CPU time (user + system) each process has used so far."""
    out = {}
    for pid in pids:
        try:
            f = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
            out[pid] = (int(f[11]) + int(f[12])) / os.sysconf("SC_CLK_TCK")
        except (OSError, IndexError, ValueError):
            pass
    return out


def _pids(mem: dict[str, int]) -> list[int]:
    return [int(k.split()[-1]) for k in mem]


def cpu_ticks() -> tuple[int, int]:
    """The machine's CPU time so far in clock ticks, all of it and the steal (the host's time on
    the guest's CPUs: ``benchmarks.hiccups``), from the ``cpu`` line of /proc/stat."""
    with open("/proc/stat") as f:
        fields = [int(x) for x in f.readline().split()[1:]]
    return sum(fields[:8]), fields[7] if len(fields) > 7 else 0


def steal_share(t0: tuple[int, int], t1: tuple[int, int]) -> str:
    total = t1[0] - t0[0]
    return f"{100.0 * (t1[1] - t0[1]) / total:.1f} %" if total > 0 else "n/a"


def late_blocks(url: str) -> int | None:
    return httpx.get(url + "/live/status", timeout=10).json().get("late_blocks")


def histogram(url: str, name: str) -> dict[str, dict[float, float]]:
    """A histogram of the server's ``/metrics``: cumulative count per bound, for each value of
    its label other than ``le`` ("" when it has none)."""
    out: dict[str, dict[float, float]] = {}
    for line in httpx.get(url + "/metrics", timeout=10).text.splitlines():
        if line.startswith(name + "_bucket{"):
            labels = line[len(name) + 8:line.index("}")]
            le = labels.split('le="', 1)[1].split('"', 1)[0]
            other = ",".join(x for x in labels.split(",") if not x.startswith("le="))
            out.setdefault(other.split('"')[1] if '"' in other else "", {})[float(le)] = \
                float(line.rsplit(" ", 1)[1])
    return out


def loop_lag_buckets(url: str) -> dict[float, float]:
    """The server's ``guitar_event_loop_lag_seconds`` histogram: cumulative count per bound."""
    return histogram(url, "guitar_event_loop_lag_seconds").get("", {})


def _phase(before: dict[float, float], after: dict[float, float]
           ) -> tuple[dict[float, float], float]:
    """A histogram's cumulative counts over a phase (two scrapes' difference), and their total."""
    delta = {le: after[le] - before.get(le, 0.0) for le in sorted(after)}
    return delta, delta.get(float("inf"), 0.0)


def _bound(delta: dict[float, float], total: float, q: float, beyond: str) -> str:
    """The bucket bound a share ``q`` of the counts falls under (``beyond`` past the last)."""
    le = next(le for le, n in delta.items() if n >= q * total)
    return beyond if le == float("inf") else f"under {le * 1e3:g} ms"


def relay_summary(before: dict[float, float], after: dict[float, float]) -> str:
    """Live blocks' relay through the API process over a phase (``guitar_live_relay_seconds``):
    how many, the bounds their p99 and p99.9 fall under, and the longest's."""
    delta, total = _phase(before, after)
    if not total:
        return "n/a (no blocks)"
    p99, p999, most = (_bound(delta, total, q, "over 1 s") for q in (0.99, 0.999, 1.0))
    return (f"{int(total)} blocks: p99 {p99}, p99.9 {p999}, longest {most}; "
            f"{int(total - delta[0.02])} over 20 ms")


def gc_pause_summary(before: dict[str, dict[float, float]],
                     after: dict[str, dict[float, float]]) -> str:
    """The garbage collector's pauses over a phase (``guitar_gc_pause_seconds``) per generation:
    how many, and the bound the longest falls under."""
    parts = []
    for gen in sorted(after):
        delta, total = _phase(before.get(gen, {}), after[gen])
        if total:
            parts.append(f"generation {gen}: {int(total)}, longest "
                         + _bound(delta, total, 1.0, "over 1 s"))
    return "; ".join(parts) or "none"


def loop_lag_summary(before: dict[float, float], after: dict[float, float]) -> str:
    """The lag over a phase from two scrapes: the bound p50 and p99 fall under, and how many
    probes were over 0.1 s and over 1 s."""
    delta, total = _phase(before, after)
    if not total:
        return "n/a (no probes)"

    def bound(q: float) -> str:
        return _bound(delta, total, q, "over 30 s")

    def over(x: float) -> int:
        return int(total - delta[x])

    return (f"{int(total)} probes: p50 {bound(0.5)}, p99 {bound(0.99)}; {over(0.1)} late by "
            f"over 100 ms, {over(1.0)} by over 1 s")


# ---- scores and jobs ----------------------------------------------------------------------------

async def probe_songs(c: httpx.AsyncClient, limits: dict) -> list[tuple[str, bytes, float]]:
    """Each corpus song with the longest ``max_seconds`` the server admits at 96 kHz, high: the
    scene it becomes (``POST /score/scene``) costed here as the server costs it
    (``engine.estimate_cost`` over ``work_per_second``) and cut to 95 % of the budget."""
    import engine

    out = []
    for rel in SONGS:
        path = CORPUS / rel
        if not path.exists():
            continue
        data, seconds = path.read_bytes(), float(limits["max_duration_s"])
        r = await c.post("/score/scene", files={"file": (path.name, data)}, data={
            "options": json.dumps({**HEAVY, "max_seconds": seconds})})
        if r.status_code != 200:
            continue
        scene = engine.Scene.model_validate(r.json())
        cost = engine.estimate_cost(scene).per_second / limits["work_per_second"]
        seconds = min(scene.duration, 0.95 * limits["max_render_s"] / cost)
        out.append((path.name, data, round(seconds, 2)))
    return out


async def score_render(c: httpx.AsyncClient, st: Stats, song: tuple[str, bytes, float]) -> None:
    name, data, seconds = song
    r = await c.post("/render/score", files={"file": (name, data)}, timeout=600, data={
        "options": json.dumps({**HEAVY, "max_seconds": seconds})})
    st.record("score render", r)
    if r.status_code == 503:
        await asyncio.sleep(min(float(r.headers.get("retry-after", 1)), 2.0))


async def job(c: httpx.AsyncClient, st: Stats, jobs: Counter, kind: str, until: float,
              song: tuple[str, bytes, float] | None, rng: random.Random) -> None:
    if kind == "scene":
        r = await c.post("/jobs", json=maximal_scene(rng.uniform(1.0, 3.0)))
    else:
        assert song is not None
        r = await c.post("/jobs", files={"file": (song[0], song[1])},
                         data={"options": json.dumps({"max_seconds": 60})})
    if r.status_code == 202:  # accepted (Stats.record expects a 200)
        st.status[f"{kind} job POST: 202"] += 1
    else:
        st.record(f"{kind} job POST", r)
    if r.status_code != 202:
        await asyncio.sleep(2.0)
        return
    jobs[f"{kind} posted"] += 1
    job_id = r.json()["id"]
    deadline = until + 240  # a job posted near the end may finish after the mixed phase
    while time.monotonic() < deadline:
        await asyncio.sleep(1.0)
        s = (await c.get(f"/jobs/{job_id}")).json()
        if s["status"] in ("done", "failed", "cancelled"):
            jobs[f"{kind} {s['status']}"] += 1
            if s["status"] == "done":
                a = await c.get(f"/jobs/{job_id}/audio")
                st.record(f"{kind} job audio", a)
            return
    jobs[f"{kind} unfinished"] += 1
    await c.delete(f"/jobs/{job_id}")


# ---- the phases ---------------------------------------------------------------------------------

async def http_client(c: httpx.AsyncClient, st: Stats, n: int, until: float) -> None:
    rng = random.Random(n)
    i = n * 100_000
    while time.monotonic() < until:
        i += 1
        x = rng.random()
        try:
            if x < 0.60:
                await small_render(c, st, i)
            elif x < 0.75:
                await small_stream(c, st, i)
            elif x < 0.85:
                await abandoned(c, st, i, "/render/stream", before=x < 0.80)
            else:
                await abandoned(c, st, i, "/render", before=True)
        except httpx.HTTPError as exc:
            st.record("transport", None, type(exc).__name__)


async def score_client(c: httpx.AsyncClient, st: Stats, songs: list, n: int, until: float) -> None:
    k = n
    while time.monotonic() < until:
        k += 1
        try:
            await score_render(c, st, songs[k % len(songs)])
        except httpx.HTTPError as exc:
            st.record("score transport", None, type(exc).__name__)


async def job_client(c: httpx.AsyncClient, st: Stats, jobs: Counter, songs: list, n: int,
                     until: float) -> None:
    rng = random.Random(1000 + n)
    k = 0
    while time.monotonic() < until:
        k += 1
        kind = "scene" if (n + k) % 2 else "score"
        try:
            await job(c, st, jobs, kind, until, songs[k % len(songs)], rng)
        except httpx.HTTPError as exc:
            st.record("job transport", None, type(exc).__name__)


async def loop_probe(c: httpx.AsyncClient, st: Stats, until: float) -> None:
    """``GET /health/live`` twice a second: how long the API process's event loop takes to answer
    (a loop blocked by serialising or parsing shows here)."""
    while time.monotonic() < until:
        t0 = time.perf_counter()
        try:
            r = await c.get("/health/live")
            st.status[f"health/live: {r.status_code}"] += 1
            st.probe_s.append(time.perf_counter() - t0)
        except httpx.HTTPError as exc:
            st.record("health/live", None, type(exc).__name__)
        await asyncio.sleep(0.5)


async def mixed(url: str, a: argparse.Namespace, songs: list) -> tuple[Stats, Counter]:
    """Every client with connections of its own (as clients on other machines have): one shared
    pool made a request wait for a connection that others' abandoned requests held, which the
    figures then counted as the server's time (a /health/live once took 32 s with the server's
    own loop never late by a second)."""
    st, jobs = Stats(), Counter()
    st.probe_s = []
    until = time.monotonic() + a.seconds

    async def own(client, *args):
        limits = httpx.Limits(max_connections=4, keepalive_expiry=2.0)
        async with httpx.AsyncClient(base_url=url, timeout=300, limits=limits) as c:
            await client(c, *args)

    await asyncio.gather(
        *(own(http_client, st, n, until) for n in range(a.clients)),
        *(own(score_client, st, songs, n, until) for n in range(a.score_clients)),
        *(own(job_client, st, jobs, songs, n, until) for n in range(a.job_clients)),
        own(loop_probe, st, until))
    return st, jobs


class _Timeline:
    """The RSS of the server and of every process below it every ``every`` seconds of the mixed
    phase (none if ``every`` is 0): whether a process's growth levels off shows in its column."""

    def __init__(self, pid: int, every: float):
        self.pid, self.every = pid, every
        self.rows: list[tuple[float, dict[str, int]]] = []
        self._stop = threading.Event()
        self._t0 = time.monotonic()
        self._thread = threading.Thread(target=self._sample, daemon=True)
        if every > 0:
            self._thread.start()

    def _sample(self) -> None:
        while not self._stop.wait(self.every):
            self.rows.append((time.monotonic() - self._t0, memory(self.pid)))

    def stop(self) -> None:
        self._stop.set()
        if self._thread.is_alive():
            self._thread.join()

    def print(self, live_pids: set[int]) -> None:
        if not self.rows:
            return
        keys = sorted({k for _, m in self.rows for k in m if not k.startswith("tracker")})
        names = [k.replace("worker", "live worker") if int(k.split()[-1]) in live_pids else k
                 for k in keys]
        print(f"\n| s into the mixed load | {' | '.join(f'{n}, MiB' for n in names)} |")
        print("| --- |" + " --- |" * len(keys))
        for t, m in self.rows:
            print(f"| {t:.0f} | {' | '.join(str(m.get(k, '-')) for k in keys)} |")


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--live-client":
        live_client(sys.argv[2], int(sys.argv[3]), float(sys.argv[4]), float(sys.argv[5]))
        return
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=180.0, help="length of the mixed phase")
    ap.add_argument("--baseline-seconds", type=float, default=30.0,
                    help="live sessions alone first, for this long")
    ap.add_argument("--clients", type=int, default=16, help="small-render/stream HTTP clients")
    ap.add_argument("--score-clients", type=int, default=2)
    ap.add_argument("--job-clients", type=int, default=2)
    ap.add_argument("--live", type=int, default=2,
                    help="live sessions (alternately dense and single plucks)")
    ap.add_argument("--server-nice", type=int, default=-10,
                    help="niceness of the server (its live workers inherit it); its render "
                         "workers are put back at 0 by GUITAR_WORKER_NICE (0: all at 0)")
    ap.add_argument("--live-realtime", type=int, default=10,
                    help="GUITAR_LIVE_REALTIME_PRIORITY of the server: its live workers' audio "
                         "thread on SCHED_RR at this priority (0: normal scheduling)")
    ap.add_argument("--relay-realtime", type=int, default=5,
                    help="GUITAR_RELAY_REALTIME_PRIORITY of the server: the API's event-loop "
                         "thread on SCHED_RR at this priority (0: normal scheduling)")
    ap.add_argument("--jitter-ms", type=float, default=40.0)
    ap.add_argument("--live-client-nice", type=int, default=-10,
                    help="niceness of the live client process (0: the default)")
    ap.add_argument("--client-nice", type=int, default=0,
                    help="niceness of this load generator, which runs every HTTP client (-10: "
                         "as if its clients were on other machines, it is not held up behind "
                         "the render workers; it still takes their CPU)")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--rss-every", type=float, default=60.0, metavar="S",
                    help="print every process's RSS every S seconds of the mixed load (0: only "
                         "before and after)")
    ap.add_argument("--env", action="append", default=[], metavar="GUITAR_X=V",
                    help="an extra setting of the server")
    a = ap.parse_args()
    load0 = os.getloadavg()
    with tempfile.TemporaryDirectory(prefix="mixed-load-") as tmp:
        env = {"GUITAR_DATA_DIR": tmp, "GUITAR_LIVE_WORKERS": "1", "GUITAR_LIVE_PRESTART": "1",
               "GUITAR_MAX_LIVE_SESSIONS": str(max(4, a.live)),
               "GUITAR_LIVE_REALTIME_PRIORITY": str(a.live_realtime),
               "GUITAR_RELAY_REALTIME_PRIORITY": str(a.relay_realtime),
               **dict(kv.split("=", 1) for kv in a.env)}
        # The server ahead of other processes, its render workers back at the default
        # (GUITAR_WORKER_NICE): its API process, which relays every live block, and its live
        # workers run ahead of renders, as an audio service's would.
        if a.server_nice:
            os.setpriority(os.PRIO_PROCESS, 0, a.server_nice)  # the server inherits it
            env["GUITAR_WORKER_NICE"] = str(-a.server_nice)
        try:
            proc, url = start_server(a.workers, env)
        finally:
            if a.server_nice or a.client_nice:
                os.setpriority(os.PRIO_PROCESS, 0, a.client_nice)  # this load generator
        try:
            run(url, proc, a, load0)
        finally:
            os.kill(proc.pid, signal.SIGTERM)
            try:
                proc.wait(30)
            except subprocess.TimeoutExpired:
                os.kill(proc.pid, signal.SIGKILL)


def run(url: str, proc: subprocess.Popen, a: argparse.Namespace, load0: tuple) -> None:
    deadline = time.monotonic() + 300
    while not httpx.get(url + "/live/status", timeout=10).json()["ready"]:
        if time.monotonic() > deadline:
            raise TimeoutError("no live worker became ready")
        time.sleep(0.5)
    limits = httpx.get(url + "/limits", timeout=10).json()

    async def songs_():
        async with httpx.AsyncClient(base_url=url, timeout=120) as c:
            return await probe_songs(c, limits)

    songs = asyncio.run(songs_())
    before = memory(proc.pid)
    live_pids = set(httpx.get(url + "/live/status", timeout=10).json()["pids"])
    cpu0, t_cpu0 = cpu_seconds(_pids(before)), time.monotonic()
    rows: list[tuple[str, str]] = []

    late0, ticks0 = late_blocks(url), cpu_ticks()
    base = live_result(start_live(url, a.live, a.baseline_seconds, a.jitter_ms,
                                  a.live_client_nice), a.baseline_seconds + 120)
    late1, ticks1 = late_blocks(url), cpu_ticks()
    lag1 = loop_lag_buckets(url)
    gc1 = histogram(url, "guitar_gc_pause_seconds")
    relay1 = histogram(url, "guitar_live_relay_seconds").get("", {})

    live = start_live(url, a.live, a.seconds, a.jitter_ms, a.live_client_nice)
    t0 = time.monotonic()
    timeline = _Timeline(proc.pid, a.rss_every)
    st, jobs = asyncio.run(mixed(url, a, songs))
    wall = time.monotonic() - t0
    timeline.stop()
    mixed_live = live_result(live, 120)
    late2, ticks2 = late_blocks(url), cpu_ticks()
    lag2 = loop_lag_buckets(url)
    gc2 = histogram(url, "guitar_gc_pause_seconds")
    relay2 = histogram(url, "guitar_live_relay_seconds").get("", {})
    drain = time.monotonic() + 120
    while time.monotonic() < drain:
        pool = httpx.get(url + "/health", timeout=10).json()["pool"]
        if pool["in_flight"] == 0 and pool["busy"] == 0:
            break
        time.sleep(0.5)
    after = memory(proc.pid)
    cpu1, span = cpu_seconds(_pids(before) + _pids(after)), time.monotonic() - t_cpu0
    health = httpx.get(url + "/health", timeout=10).json()["pool"]
    load1 = os.getloadavg()

    def server_late(x: int | None, y: int | None) -> str:
        return "n/a" if x is None or y is None else str(y - x)

    xs, sv = st.small_s, st.small_server_s
    errors = [k for k in st.status if any(f": {c}" in k for c in (500, 502, 504))]
    rows += [
        ("small renders", f"{len(xs)} answered 200: p50 {_pct(xs, 50) * 1e3:.0f} ms, "
                          f"p99 {_pct(xs, 99) * 1e3:.0f} ms, max {max(xs, default=0) * 1e3:.0f} ms"),
        ("small renders, the server's own time (Server-Timing)",
         f"p50 {_pct(sv, 50) * 1e3:.0f} ms, p99 {_pct(sv, 99) * 1e3:.0f} ms, "
         f"max {max(sv, default=0) * 1e3:.0f} ms"),
        (f"live, {a.live} sessions alone ({a.baseline_seconds:g} s)",
         f"{base['late']} underruns in {base['blocks']} blocks (worst "
         f"{base.get('worst_late_ms', 0)} ms late); server late blocks "
         f"{server_late(late0, late1)}; steal {steal_share(ticks0, ticks1)}"),
        (f"live, {a.live} sessions in the mixed load",
         f"{mixed_live['late']} underruns in {mixed_live['blocks']} blocks (worst "
         f"{mixed_live.get('worst_late_ms', 0)} ms late); server late blocks "
         f"{server_late(late1, late2)}; steal {steal_share(ticks1, ticks2)}; "
         f"{mixed_live.get('refused', 0)} events refused, "
         f"{len(mixed_live.get('failed', []))} sessions failed"),
        ("API loop lag in the mixed load, the server's own probe",
         loop_lag_summary(lag1, lag2)),
        ("API garbage collector's pauses in the mixed load", gc_pause_summary(gc1, gc2)),
        ("live blocks' relay through the API process in the mixed load (from the live worker to "
         "the socket)", relay_summary(relay1, relay2)),
        ("API loop: GET /health/live during the load",
         f"p50 {_pct(st.probe_s, 50) * 1e3:.0f} ms, p99 {_pct(st.probe_s, 99) * 1e3:.0f} ms, "
         f"max {max(st.probe_s, default=0) * 1e3:.0f} ms"),
        ("5xx other than 503 + Retry-After", f"{sum(st.status[k] for k in errors)}"
         + (f" ({', '.join(errors)})" if errors else "")),
        ("unexpected answers", f"{len(st.unexpected)}"
         + (f": {'; '.join(st.unexpected[:3])}" if st.unexpected else "")),
        ("jobs", ", ".join(f"{k} {n}" for k, n in sorted(jobs.items())) or "none"),
        ("workers replaced / hung", f"{health['replaced']} / {health['hung']}"),
    ]
    print(f"\nMixed load: {a.clients} HTTP clients, {a.score_clients} score clients "
          f"({len(songs)} corpus songs at 96 kHz, high, up to the cost budget), {a.job_clients} "
          f"job clients, {a.live} live sessions (niceness: server {a.server_nice}, render workers "
          f"0, HTTP clients {a.client_nice}, live client {a.live_client_nice}; live audio thread "
          f"{f'SCHED_RR {a.live_realtime}' if a.live_realtime else 'normal'}, API loop thread "
          f"{f'SCHED_RR {a.relay_realtime}' if a.relay_realtime else 'normal'}); {a.seconds:g} s "
          f"({wall:.0f} s with the last answers), {a.workers} render workers, 1 live worker; "
          f"load average {load0[0]:.1f} before, {load1[0]:.1f} after ({os.cpu_count()} CPUs, shared)\n")
    print("| measure | result |")
    print("| --- | --- |")
    for name, value in rows:
        print(f"| {name} | {value} |")
    print("\n| answers | count |")
    print("| --- | --- |")
    for key, n in sorted(st.status.items()):
        print(f"| {key} | {n} |")
    print(f"\n| process | RSS before, MiB | RSS after, MiB | CPU s per s over the {span:.0f} s "
          "of both phases |")
    print("| --- | --- | --- | --- |")
    for key in sorted(set(before) | set(after)):
        pid = int(key.split()[-1])
        used = cpu1.get(pid, 0.0) - cpu0.get(pid, 0.0) if pid in cpu1 else None
        name = key.replace("worker", "live worker") if pid in live_pids else key
        print(f"| {name} | {before.get(key, '-')} | {after.get(key, '-')} | "
              f"{'-' if used is None else f'{used / span:.2f}'} |")
    timeline.print(live_pids)
    if mixed_live.get("failed"):
        print("live sessions failed:", mixed_live["failed"])


if __name__ == "__main__":
    main()
