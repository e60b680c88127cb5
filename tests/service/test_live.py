"""WS /live against a real uvicorn process on 127.0.0.1: the audio streamed is the session's (equal
to the offline render of the same events at the frames the server acknowledged), every bad message
is answered with an error naming its field while the session goes on, and the session limit and the
idle timeout close the socket with their codes."""

from __future__ import annotations

import asyncio
import json
import struct
import time
from collections import Counter
from collections.abc import Iterator

import httpx
import numpy as np
import pytest
import websockets
from conftest import UvicornServer, wait_ready

import engine

HEADER = struct.Struct("<Q")
IDLE_S = 2.0


@pytest.fixture(scope="module")
def live_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[UvicornServer]:
    s = UvicornServer(tmp_path_factory.mktemp("live"), {
        "GUITAR_WORKERS": "1", "GUITAR_LIVE_WORKERS": "1", "GUITAR_MAX_LIVE_SESSIONS": "2",
        "GUITAR_LIVE_IDLE_TIMEOUT_S": str(IDLE_S), "GUITAR_LIVE_PRESTART": "1"}).start()
    wait_ready(lambda: httpx.get(s.url + "/live/status", timeout=2.0).json()["ready"])
    yield s
    s.stop()


def ws_url(server: UvicornServer) -> str:
    return server.url.replace("http://", "ws://") + "/live"


OPEN = {"type": "open", "preset": "steel-acoustic", "sample_rate": 44100, "block_frames": 256}


def relay_count(server: UvicornServer) -> float:
    return next((float(x.split()[-1]) for x in httpx.get(server.url + "/metrics").text.splitlines()
                 if x.startswith("guitar_live_relay_seconds_count")), 0.0)


async def _next_text(ws) -> dict:
    while True:
        m = await asyncio.wait_for(ws.recv(), 10.0)
        if isinstance(m, str):
            return json.loads(m)


@pytest.mark.parametrize("model", ["fdtd", "waveguide"])
def test_streamed_audio_is_the_offline_render_of_the_acknowledged_events(live_server, model):
    async def play():
        blocks: dict[int, np.ndarray] = {}
        acks: dict[str, int] = {}
        async with websockets.connect(ws_url(live_server)) as ws:
            await ws.send(json.dumps({**OPEN, "model": model}))
            opened = json.loads(await ws.recv())
            assert opened["type"] == "opened" and opened["block_frames"] == 256
            assert opened["model"] == model
            assert opened["delay_frames"] == (256 if model == "waveguide" else 0)
            script = [(0.05, {"type": "fret", "string": 5, "fret": 3, "id": "f"}),
                      (0.0, {"type": "pluck", "string": 5, "offset": 100, "id": "p1"}),
                      (0.15, {"type": "strum", "force": 1.5, "id": "s"}),
                      (0.1, {"type": "bend", "string": 5, "semitones": 1, "duration": 0.05,
                             "id": "b"}),
                      (0.1, {"type": "release", "string": 5, "id": "r"})]

            async def receive():
                async for m in ws:
                    if isinstance(m, bytes):
                        blocks[HEADER.unpack(m[:8])[0]] = np.frombuffer(m[8:], "<f4")
                    else:
                        body = json.loads(m)
                        assert body["type"] == "ack", body
                        acks[body["id"]] = body["frame"]

            task = asyncio.create_task(receive())
            for pause, msg in script:
                await asyncio.sleep(pause)
                await ws.send(json.dumps(msg))
            await asyncio.sleep(0.5)
            await ws.close()
            await task
        return blocks, acks

    relayed = relay_count(live_server)
    blocks, acks = asyncio.run(play())
    assert set(acks) == {"f", "p1", "s", "b", "r"}
    frames = sorted(blocks)
    assert frames == list(range(0, 256 * len(frames), 256))  # every block, in order
    # each block's relay through the API process is timed (guitar_live_relay_seconds)
    assert relay_count(live_server) - relayed >= len(frames)
    audio = np.concatenate([blocks[f] for f in frames])
    rate = 44100
    t = {k: f / rate for k, f in acks.items()}
    scene = {"duration": len(audio) / rate, "sample_rate": rate, "quality": "draft",
             "model": model, "events": [
        {"type": "fret", "time": t["f"], "string": 5, "fret": 3, "release": t["r"]},
        {"type": "pluck", "time": t["p1"], "string": 5},
        {"type": "strum", "time": t["s"], "force": 1.5},
        {"type": "bend", "time": t["b"], "string": 5, "semitones": 1, "duration": 0.05,
         "release": t["r"]}]}
    ref = np.concatenate(list(engine.blocks(scene, 256, engine.RenderOptions(live_grid=True))))
    assert np.max(np.abs(audio)) > 0.01
    assert np.array_equal(audio, ref.astype("<f4"))


BAD = [
    ("not json", "message", "not JSON"),
    (b"\x00\x01binary", "message", "binary"),
    (json.dumps([1, 2]), "message", "object"),
    (json.dumps({"type": "strike", "string": 1}), "type", "unknown event type"),
    (json.dumps({"type": "pluck", "string": 1, "force": 50}), "force", "less than or equal"),
    (json.dumps({"type": "pluck", "string": 9}), "string", "outside 1..6"),
    (json.dumps({"type": "fret", "string": 1, "fret": 30}), "fret", "24"),
    (json.dumps({"type": "pluck", "string": 1, "offset": 999}), "offset", "0..255"),
    (json.dumps({"type": "pluck", "string": 1, "time": 1.0}), "time", "not taken"),
    (json.dumps({"type": "pluck", "string": 1, "id": [1]}), "id", "string or number"),
    (json.dumps(OPEN), "type", "already open"),
]


def test_bad_messages_are_answered_and_the_session_goes_on(live_server):
    async def play():
        answers = []
        async with websockets.connect(ws_url(live_server)) as ws:
            # an event before the open, and a bad open
            await ws.send(json.dumps({"type": "pluck", "string": 1}))
            answers.append(await _next_text(ws))
            await ws.send(json.dumps({**OPEN, "block_frames": 5}))
            answers.append(await _next_text(ws))
            await ws.send(json.dumps({**OPEN, "model": "spline"}))
            answers.append(await _next_text(ws))
            await ws.send(json.dumps(OPEN))
            assert (await _next_text(ws))["type"] == "opened"
            for msg, _, _ in BAD:
                await ws.send(msg)
                answers.append(await _next_text(ws))
            # a bend while one is held: refused by the session itself (in the worker)
            await ws.send(json.dumps({"type": "bend", "string": 2, "semitones": 1, "id": 1}))
            await ws.send(json.dumps({"type": "bend", "string": 2, "semitones": 2, "id": 2}))
            while (answer := await _next_text(ws))["type"] == "ack":
                pass  # the first bend's ack may come before the second's refusal
            answers.append(answer)
            await ws.send(json.dumps({"type": "pluck", "string": 1, "id": "ok"}))
            while (last := await _next_text(ws)).get("id") != "ok":
                if last["type"] != "ack":  # the first bend's ack may come after the refusal
                    answers.append(last)
            return answers, last

    answers, last = asyncio.run(play())
    assert answers[0]["field"] == "type" and "open the session first" in answers[0]["message"]
    assert answers[1]["field"] == "block_frames"
    assert answers[2]["field"] == "model" and "'waveguide'" in answers[2]["message"], answers[2]
    answers = answers[:2] + answers[3:]
    for answer, (_, field, text) in zip(answers[2:], BAD, strict=False):
        assert answer["type"] == "error"
        assert answer["field"] == field, answer
        assert text in answer["message"], answer
    refused = answers[2 + len(BAD)]
    assert refused["id"] == 2 and refused["field"] == "type" and "bend" in refused["message"]
    assert last == {"type": "ack", "id": "ok", "frame": last["frame"]}


def test_session_limit_closes_with_1013(live_server):
    async def play():
        async with websockets.connect(ws_url(live_server)) as a, \
                websockets.connect(ws_url(live_server)) as b:
            for ws in (a, b):
                await ws.send(json.dumps(OPEN))
                assert (await _next_text(ws))["type"] == "opened"
            async with websockets.connect(ws_url(live_server)) as c:
                await c.send(json.dumps(OPEN))
                with pytest.raises(websockets.ConnectionClosed) as closed:
                    await _next_text(c)
                return closed.value.rcvd

    rcvd = asyncio.run(play())
    assert rcvd.code == 1013 and "limit is 2" in rcvd.reason
    # the slots are free again once those sessions closed
    deadline = time.monotonic() + 5
    while httpx.get(live_server.url + "/live/status").json()["live_sessions"]:
        assert time.monotonic() < deadline
        time.sleep(0.1)


def test_a_new_guitar_is_prepared_while_the_other_sessions_play(live_server):
    """A guitar the worker has not prepared (here one with an action no store has seen, on the
    waveguide: the finger's damping analysed at every fret, seconds) is prepared beside the loop:
    the session already playing on the same worker gets its blocks on time meanwhile."""
    action = 3e-3 + (time.time_ns() % 10**6) * 1e-12  # new on every run: nothing stored
    new = {**OPEN, "model": "waveguide", "guitar": {"action_12th_m": action, "frets": 12}}

    async def play():
        arrivals: list[float] = []
        async with websockets.connect(ws_url(live_server)) as a:
            await a.send(json.dumps(OPEN))
            assert (await _next_text(a))["type"] == "opened"

            async def receive():
                async for m in a:
                    if isinstance(m, bytes):
                        arrivals.append(time.monotonic())

            async def keep_playing():  # events, so that the idle timeout leaves it open
                while True:
                    await a.send(json.dumps({"type": "pluck", "string": 1}))
                    await asyncio.sleep(0.5)

            tasks = [asyncio.create_task(receive()), asyncio.create_task(keep_playing())]
            await asyncio.sleep(0.3)
            async with websockets.connect(ws_url(live_server)) as b:
                t_open = time.monotonic()
                await b.send(json.dumps(new))
                opened = await asyncio.wait_for(_next_text(b), 60.0)
                t_opened = time.monotonic()
            await asyncio.sleep(0.3)
            tasks[1].cancel()
            await a.close()
            await tasks[0]
        return opened, t_open, t_opened, arrivals

    opened, t_open, t_opened, arrivals = asyncio.run(play())
    assert opened["type"] == "opened" and opened["model"] == "waveguide", opened
    assert t_opened - t_open > 1.0  # the preparation took long enough for a stall to show
    during = [t for t in arrivals if t_open - 0.1 <= t <= t_opened + 0.1]
    gaps = np.diff(during)
    assert len(during) > 10 and gaps.max() < 0.5, (len(during), gaps.max())


def test_idle_session_is_closed_with_4408(live_server):
    async def play():
        async with websockets.connect(ws_url(live_server)) as ws:
            await ws.send(json.dumps(OPEN))
            assert (await _next_text(ws))["type"] == "opened"
            t0 = time.monotonic()
            with pytest.raises(websockets.ConnectionClosed) as closed:
                while True:
                    await asyncio.wait_for(ws.recv(), 10.0)
            return closed.value.rcvd, time.monotonic() - t0

    rcvd, waited = asyncio.run(play())
    assert rcvd.code == 4408 and "idle" in rcvd.reason
    assert IDLE_S - 0.2 < waited < IDLE_S + 3.0


def test_a_message_flood_is_closed_with_4429(live_server):
    """300k messages in 3 s were answered one error each and never closed: past
    GUITAR_LIVE_MAX_MESSAGES_PER_S (400) messages in a second the session is closed, 4429."""
    async def play():
        async with websockets.connect(ws_url(live_server)) as ws:
            await ws.send(json.dumps(OPEN))
            assert (await _next_text(ws))["type"] == "opened"
            t0 = time.monotonic()
            with pytest.raises(websockets.ConnectionClosed) as closed:
                for _ in range(3000):
                    await ws.send("not json")
                while True:
                    await asyncio.wait_for(ws.recv(), 10.0)
            return closed.value.rcvd, time.monotonic() - t0

    rcvd, took = asyncio.run(play())
    assert rcvd is not None and rcvd.code == 4429, rcvd
    assert "GUITAR_LIVE_MAX_MESSAGES_PER_S" in rcvd.reason and took < IDLE_S


def test_a_normal_close_logs_no_traceback(live_server):
    """Closing while blocks are being sent logged "Task exception was never retrieved ...
    WebSocketDisconnect" with a traceback."""
    async def play():
        for _ in range(6):
            async with websockets.connect(ws_url(live_server)) as ws:
                await ws.send(json.dumps(OPEN))
                assert (await _next_text(ws))["type"] == "opened"
                await ws.send(json.dumps({"type": "pluck", "string": 1}))
                for _ in range(20):
                    await asyncio.wait_for(ws.recv(), 10.0)
            await asyncio.sleep(0.2)

    asyncio.run(play())
    time.sleep(1.0)  # a task's lost exception is logged when it is collected
    log = "\n".join(live_server.log_lines())
    assert "never retrieved" not in log and "Traceback" not in log, log[-3000:]


def test_the_live_worker_keeps_what_its_warm_up_made_out_of_the_collectors_sight(live_server):
    """A full garbage collection of a warmed engine process walks over a hundred thousand
    objects, tens of ms on the audio thread: more than the 20 ms lead, so each made a burst of
    late blocks.  The live worker freezes them after its warm-up and says how many in its log."""
    lines = [json.loads(x) for x in live_server.log_lines() if x.startswith("{")]
    ready = [x for x in lines if x.get("msg") == "live worker ready"]
    assert ready and all(x["gc_frozen"] > 50_000 for x in ready), ready


def _may_use_realtime() -> bool:
    """Whether this machine lets a process put a thread on SCHED_RR (CAP_SYS_NICE)."""
    import os
    import threading

    ok = []

    def probe() -> None:
        try:
            os.sched_setscheduler(0, os.SCHED_RR, os.sched_param(1))
            os.sched_setscheduler(0, os.SCHED_OTHER, os.sched_param(0))
            ok.append(True)
        except (OSError, AttributeError):
            pass

    t = threading.Thread(target=probe)
    t.start()
    t.join()
    return bool(ok)


def test_the_live_audio_thread_runs_at_real_time_priority_and_its_preparer_does_not(
        tmp_path_factory):
    """GUITAR_LIVE_REALTIME_PRIORITY: the thread that computes every block on SCHED_RR (in the
    mixed load, blocks the live worker finished late went from hundreds to those of the session
    alone), the thread that prepares a new guitar (a fifth of a second to seconds) on normal
    scheduling, so that it cannot hold a core ahead of everything else."""
    import os

    if not _may_use_realtime():
        pytest.skip("no CAP_SYS_NICE here: SCHED_RR cannot be set")
    s = UvicornServer(tmp_path_factory.mktemp("live-rt"), {
        "GUITAR_WORKERS": "1", "GUITAR_LIVE_WORKERS": "1", "GUITAR_LIVE_PRESTART": "1",
        "GUITAR_LIVE_REALTIME_PRIORITY": "10"}).start()
    try:
        wait_ready(lambda: httpx.get(s.url + "/live/status", timeout=2.0).json()["ready"])
        pid = httpx.get(s.url + "/live/status", timeout=5).json()["pids"][0]
        assert os.sched_getscheduler(pid) == os.SCHED_RR
        assert os.sched_getparam(pid).sched_priority == 10
        new = {**OPEN, "model": "waveguide", "guitar": {  # prepared by the preparer, seconds
            "action_12th_m": 3e-3 + (time.time_ns() % 10**6) * 1e-12, "frets": 12}}

        async def play() -> dict:
            async with websockets.connect(ws_url(s)) as ws:
                await ws.send(json.dumps(new))
                while True:
                    m = await asyncio.wait_for(ws.recv(), 120.0)
                    if isinstance(m, str):
                        return json.loads(m)

        assert asyncio.run(play())["type"] == "opened"
        others = [int(t) for t in os.listdir(f"/proc/{pid}/task") if int(t) != pid]
        assert others  # the preparer's thread, at least
        assert all(os.sched_getscheduler(t) == os.SCHED_OTHER for t in others)
    finally:
        s.stop()


def _children(pid: int) -> set[int]:
    import os

    out: set[int] = set()
    for tid in os.listdir(f"/proc/{pid}/task"):
        with open(f"/proc/{pid}/task/{tid}/children") as f:
            out |= {int(c) for c in f.read().split()}
    return out


def _render_workers(pid: int, live_pids: list[int]) -> set[int]:
    workers = set()
    for c in _children(pid) - set(live_pids):
        with open(f"/proc/{c}/cmdline", "rb") as f:
            if b"spawn_main" in f.read():  # not the resource tracker
                workers.add(c)
    return workers


def test_the_relay_runs_at_real_time_priority_and_what_it_starts_later_does_not(
        tmp_path_factory):
    """GUITAR_RELAY_REALTIME_PRIORITY: the API process's event-loop thread, which hands every live
    block to its socket, on SCHED_RR (in the mixed load, blocks relayed over 20 ms late went from
    1317-3000 a run to 37-365, underruns from 2 to 0-4); the processes and threads it starts
    afterwards, like a render worker that replaces a killed one, on normal scheduling, or every
    render would run ahead of everything else; so are its threads, except the live worker's pipe
    reader, which hands the blocks to the loop."""
    import os
    import signal as sig

    if not _may_use_realtime():
        pytest.skip("no CAP_SYS_NICE here: SCHED_RR cannot be set")
    s = UvicornServer(tmp_path_factory.mktemp("relay-rt"), {
        "GUITAR_WORKERS": "1", "GUITAR_LIVE_WORKERS": "1", "GUITAR_LIVE_PRESTART": "1",
        "GUITAR_RELAY_REALTIME_PRIORITY": "5"}).start()
    try:
        wait_ready(lambda: httpx.get(s.url + "/health/ready", timeout=2.0).status_code == 200)
        pid = s.proc.pid
        assert os.sched_getscheduler(pid) & ~os.SCHED_RESET_ON_FORK == os.SCHED_RR
        assert os.sched_getparam(pid).sched_priority == 5
        live = httpx.get(s.url + "/live/status", timeout=5).json()["pids"]
        (old,) = _render_workers(pid, live)
        os.kill(old, sig.SIGKILL)
        wait_ready(lambda: (lambda w: len(w) == 1 and old not in w)(_render_workers(pid, live)))
        (new,) = _render_workers(pid, live)
        assert os.sched_getscheduler(new) == os.SCHED_OTHER
        threads = [int(t) for t in os.listdir(f"/proc/{pid}/task") if int(t) != pid]
        policies = Counter(os.sched_getscheduler(t) & ~os.SCHED_RESET_ON_FORK for t in threads)
        # the live worker's pipe reader, which hands each block to the loop, is on SCHED_RR too
        assert policies[os.SCHED_RR] == 1 and policies[os.SCHED_OTHER] >= 2
        assert set(policies) == {os.SCHED_RR, os.SCHED_OTHER}
    finally:
        s.stop()


def test_a_killed_live_worker_ends_its_sessions_with_1011_and_is_replaced(live_server):
    """A live worker killed mid-session shows up as its pipe's end: its sessions are closed with
    1011, and a new worker plays the next session.  (Last in this file: it replaces the module's
    live worker.)"""
    import os
    import signal

    pid = httpx.get(live_server.url + "/live/status", timeout=5).json()["pids"][0]

    async def killed() -> websockets.frames.Close:
        async with websockets.connect(ws_url(live_server)) as ws:
            await ws.send(json.dumps(OPEN))
            assert (await _next_text(ws))["type"] == "opened"
            await asyncio.wait_for(ws.recv(), 10.0)  # blocks are coming
            os.kill(pid, signal.SIGKILL)
            with pytest.raises(websockets.ConnectionClosed) as closed:
                while True:
                    await asyncio.wait_for(ws.recv(), 10.0)
            return closed.value.rcvd

    rcvd = asyncio.run(killed())
    assert rcvd.code == 1011 and "replaced" in rcvd.reason
    wait_ready(lambda: (lambda st: st["ready"] and pid not in st["pids"])(
        httpx.get(live_server.url + "/live/status", timeout=2.0).json()))

    async def plays() -> int:
        async with websockets.connect(ws_url(live_server)) as ws:
            await ws.send(json.dumps(OPEN))
            assert (await _next_text(ws))["type"] == "opened"
            return len(await asyncio.wait_for(ws.recv(), 10.0))

    assert asyncio.run(plays()) == HEADER.size + 256 * 4
    wait_ready(lambda: httpx.get(live_server.url + "/live/status",
                                 timeout=2.0).json()["live_sessions"] == 0, 10.0)


def test_a_sessions_first_block_is_not_counted_late() -> None:
    """Block 0 of a session plays when the session opens (the schedule that puts every later
    block 20 ms ahead of the client's clock, which starts at block 0's arrival), so it always
    finished after its play time: each session added one to ``late_blocks`` of GET /live/status,
    which counts the underruns the server caused.  A later block past its play time counts."""
    from types import SimpleNamespace

    from service import live_worker

    sent: list[tuple] = []
    session = SimpleNamespace(block_frames=256, sample_rate=44100, frame=0,
                              block=lambda: np.zeros(256))
    live = live_worker._Live(session, 0.02)
    live_worker._block(SimpleNamespace(send=sent.append), {1: live}, 1)
    assert [m for m in sent if m[0] == "late"] == []
    live.t0 -= 1.0  # block 1's play time long past
    live_worker._block(SimpleNamespace(send=sent.append), {1: live}, 1)
    assert [m[:3] for m in sent if m[0] == "late"] == [("late", 1, 1)]
