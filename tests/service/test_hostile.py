"""Hostile-but-legal requests (issue 28), each class with variants: no 500 and no dropped
connection; costs bounded before admission; clients that leave stop costing; liveness and
readiness apart, a hung worker replaced; heavy renders leave a worker to small ones."""

from __future__ import annotations

import asyncio
import json
import os
import signal
import socket
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
from conftest import AppHarness, UvicornServer, wait_ready
from fastapi.exceptions import RequestValidationError
from svc_helpers import brief, decode, heavy_scene, pluck_scene, same_bytes

import engine
from service.config import Settings
from service.validation import check_limits
from tests.score_files import small_midi


@pytest.fixture(scope="module")
def client(server: UvicornServer) -> Iterator[httpx.Client]:
    with httpx.Client(base_url=server.url, timeout=60.0) as c:
        yield c


def _raw(client: httpx.Client, body: bytes, path: str = "/render") -> httpx.Response:
    return client.post(path, content=body, headers={"content-type": "application/json"})


def _detail(r: httpx.Response) -> list[dict]:
    assert 400 <= r.status_code < 500, brief(r)
    return r.json()["detail"]


# ---- bodies that once gave a 500 or a dropped connection (over real HTTP) ---------------------

LITERALS = {
    # body -> the field the 422 must name
    b'{"duration": 0.1, "events": [{"type": "pluck", "time": 0, "string": 1, "force": 1e309}]}':
        "events[0].force",
    b'{"duration": 1e309}': "duration",
    b'{"duration": -1e400}': "duration",
    b'{"duration": 0.1, "output": {"pan": [0, 0, 0, 0, 0, 1e999]}}': "output.pan[5]",
    b'{"duration": 0.1, "sample_rate": ' + b"4" * 5000 + b"}": "sample_rate",
    b'{"duration": 0.1, "events": [{"type": "pluck", "time": 0, "string": -' + b"1" * 5000
    + b"}]}": "events[0].string",
    b'{"duration": 0.1, "guitar": {"frets": ' + b"9" * 101 + b"}}": "guitar.frets",
}


@pytest.mark.parametrize("body", list(LITERALS), ids=range(len(LITERALS)))
@pytest.mark.parametrize("path", ["/render", "/render/stream"])
def test_number_literals_out_of_range_are_422_at_their_field(client, body, path) -> None:
    detail = _detail(_raw(client, body, path))
    assert LITERALS[body] in [d["field"] for d in detail], detail
    assert any("finite" in d["message"] or "digits" in d["message"] for d in detail), detail


SURROGATES = [
    ('{"duration": 0.1, "guitar": {"preset": "\\ud800"}}', "guitar.preset"),
    ('{"duration": 0.1, "guitar": {"tuning": ["\\udfff"]}}', "guitar.tuning[0]"),
    ('{"duration": 0.1, "events": [{"type": "\\ud800x", "time": 0, "string": 1}]}', "events[0]"),
    ('{"duration": 0.1, "\\ud800": 1}', ""),  # a key pydantic cannot read: the body
    ('{"duration": 0.1, "quality": "\\udbff\\udfff\\ud800"}', "quality"),
]


@pytest.mark.parametrize("body, field", SURROGATES)
def test_lone_surrogates_are_echoed_escaped(client, body, field) -> None:
    r = _raw(client, body.encode())
    detail = _detail(r)
    assert r.status_code == 422
    assert field in [d["field"] for d in detail], detail
    r.content.decode("utf-8")  # the body is valid UTF-8


@pytest.mark.parametrize("scene, field", [
    ({"duration": 0.1, "events": [{"type": "fret", "time": 0, "string": 1, "fret": 2,
                                   "release": 1e15}]}, "events[0].release"),
    ({"duration": 0.1, "events": [{"type": "mute", "time": 0, "release": 1e300}]},
     "events[0].release"),
    ({"duration": 0.1, "guitar": {"tuning": ["E99999"] * 6}}, "guitar.tuning"),
    ({"duration": 0.1, "guitar": {"strings": [{"string": 1, "note": "C-99"}]}},
     "guitar.strings[0].note"),
    ({"duration": 0.1, "sample_rate": 95999, "output": {"format": "flac"}}, "sample_rate"),
    ({"duration": 0.1, "sample_rate": 65536, "output": {"format": "flac"}}, "sample_rate"),
    ({"duration": 1e-6, "output": {"format": "flac"}}, "duration"),
    ({"duration": 1e-6, "output": {"format": "wav"}}, "duration"),
    ({"duration": True}, "duration"),
    ({"duration": 0.1, "sample_rate": "44100"}, "sample_rate"),
    ({"duration": 0.1, "events": [{"type": "pluck", "time": 0, "string": 1.0}]},
     "events[0].string"),
    ({"duration": 0.1, "output": {"channels": True}}, "output.channels"),
])
def test_values_the_validator_owns_are_422_naming_the_field(client, scene, field) -> None:
    for path in ("/render", "/render/stream"):
        r = client.post(path, json=scene)
        assert r.status_code == 422, brief(r)
        assert field in [d["field"] for d in r.json()["detail"]], r.json()


@pytest.mark.parametrize("rate", [65540, 96000, 44100])
def test_flac_at_rates_it_carries_decodes(client, rate) -> None:
    r = client.post("/render", json=pluck_scene(0.05, sample_rate=rate, output={"format": "flac"}))
    assert r.status_code == 200, brief(r)
    x, got, _ = decode(r.content)
    assert got == rate and len(x) == round(0.05 * rate)


def test_a_one_sample_scene_decodes_in_every_format(client) -> None:
    for fmt in ("wav", "flac", "ogg"):
        r = client.post("/render", json=pluck_scene(1 / 44100, output={"format": fmt}))
        assert r.status_code == 200, brief(r)
        x, _, _ = decode(r.content)
        assert len(x) == 1


# ---- cost known before admission ---------------------------------------------------------------

@pytest.mark.parametrize("events, expanded", [
    ([{"type": "strum", "time": 0.001 * i} for i in range(20)], 120),
    ([{"type": "mute", "time": 0.001 * i} for i in range(17)], 102),
    ([{"type": "strum", "time": 0.0, "strings": [1, 2]}] * 51, 102),
])
def test_expanded_events_count_against_the_limit(events, expanded) -> None:
    scene = engine.Scene.model_validate({"duration": 1.0, "events": events})
    with pytest.raises(RequestValidationError) as info:
        check_limits(scene, Settings(max_expanded_events=100))
    d = info.value.errors()[0]
    assert d["loc"] == ("body", "events") and "GUITAR_MAX_EXPANDED_EVENTS" in d["msg"], d
    assert d["input"] == expanded
    check_limits(scene, Settings(max_expanded_events=expanded))


def test_a_strum_of_125000_strings_is_refused_by_the_schema(client) -> None:
    # the schema refuses a strings list beyond the preset, before any expansion
    r = client.post("/render", json={"duration": 1.0, "events": [
        {"type": "strum", "time": 0, "strings": [1] * 125_000}]})
    assert r.status_code in (413, 422)


@pytest.mark.parametrize("scene", [
    heavy_scene(30.0),  # 96 kHz, high, six fingered strings
    {**heavy_scene(20.0), "sample_rate": 88200},
])
def test_a_scene_over_the_cost_budget_is_refused_with_what_would_fit(client, scene) -> None:
    t0 = time.monotonic()
    r = client.post("/render", json=scene)
    assert time.monotonic() - t0 < 2.0  # refused up front, not after rendering
    assert r.status_code == 422, brief(r)
    d = r.json()["detail"][0]
    assert d["field"] == "duration" and "GUITAR_MAX_RENDER_S" in d["message"]
    most = d["ctx"]["le"]
    assert 0 < most < scene["duration"]
    ok = client.post("/render", json={**scene, "duration": most * 0.05})  # well inside the budget
    assert ok.status_code == 200, brief(ok)


# ---- a client that leaves stops costing ----------------------------------------------------------

def _send(url: str, path: str, scene: dict) -> socket.socket:
    """A request sent on a socket of its own, whose answer is never read (close it to leave)."""
    host, port = url.removeprefix("http://").split(":")
    if path.endswith("+score"):  # the score form of /render/score or /jobs: its import queues
        request = httpx.Request("POST", url + path.removesuffix("+score"),
                                files={"file": ("s.mid", small_midi(), "audio/midi")})
        body = request.read()
        head = "".join(f"{k}: {v}\r\n" for k, v in request.headers.items())
        start = f"POST {path.removesuffix('+score')} HTTP/1.1\r\n{head}\r\n"
    else:
        body = json.dumps(scene).encode()
        start = (f"POST {path} HTTP/1.1\r\nHost: {host}\r\nContent-Type: application/json\r\n"
                 f"Content-Length: {len(body)}\r\n\r\n")
    s = socket.create_connection((host, int(port)))
    s.sendall(start.encode() + body)
    return s


@pytest.fixture(scope="module")
def all_heavy_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[UvicornServer]:
    """Two workers that any render may hold (no heavy class): to fill both with long renders."""
    tmp = tmp_path_factory.mktemp("allheavy")
    s = UvicornServer(tmp, {"GUITAR_WORKERS": "2", "GUITAR_HEAVY_RENDER_S": "1000",
                            "GUITAR_DATA_DIR": str(tmp / "data")}).start()
    yield s
    s.stop()


@pytest.mark.parametrize("path", ["/render/stream", "/render", "/render/score+score",
                                  "/jobs+score"])
def test_requests_abandoned_while_queued_stop_costing(all_heavy_server, path) -> None:
    """A score's import waits in the same queue: /render/score and a score job whose client left
    leave it too (and no job is made of them)."""
    server = all_heavy_server
    client = httpx.Client(base_url=server.url, timeout=60)
    busy = [heavy_scene(4.0 + 0.001 * i) for i in range(2)]  # seconds of work each
    # the blockers' own timeout: minutes on a busy machine
    other = httpx.Client(base_url=server.url, timeout=300)
    blocker = [other.build_request("POST", "/render", json=s) for s in busy]
    with client, other:
        import threading

        results = []
        threads = [threading.Thread(target=lambda r=r: results.append(other.send(r)))
                   for r in blocker]
        for t in threads:
            t.start()
        wait_ready(lambda: client.get("/health").json()["pool"]["busy"] == 2, 30)
        # six queued behind the two (all of them: the queue holds 8), then abandoned together
        socks = [_send(server.url, path, heavy_scene(4.0 + 0.01 * (i + 1))) for i in range(6)]
        wait_ready(lambda: client.get("/health").json()["pool"]["in_flight"] == 8, 10)
        for s in socks:
            s.close()
        # they leave the queue within a few disconnect polls, long before the workers are free
        wait_ready(lambda: client.get("/health").json()["pool"]["in_flight"] <= 2, 5)
        assert client.get("/health").json()["pool"]["busy"] == 2  # the blockers still run
        for t in threads:
            t.join(300)
        assert sorted(r.status_code for r in results) == [200, 200]
        t0 = time.monotonic()
        wait_ready(lambda: client.get("/health").json()["pool"]["busy"] == 0, 10)
        assert time.monotonic() - t0 < 1.0  # nothing of theirs is rendered after
        jobs = [ln for ln in client.get("/metrics").text.splitlines()
                if ln.startswith("guitar_jobs{")]
        assert jobs and all(ln.endswith(" 0.0") for ln in jobs), jobs  # no job made of them


def test_a_running_render_whose_client_left_stops_and_its_worker_serves_on(all_heavy_server
                                                                            ) -> None:
    """A render under the heavy class ran to its end after its client left (seconds of a worker
    for nobody); a heavy one had its worker killed and replaced (a warm-up's CPU).  Now both stop
    between two blocks and the same worker takes the next request."""
    server = all_heavy_server
    client = httpx.Client(base_url=server.url, timeout=60)
    with client:
        wait_ready(lambda: client.get("/health").json()["pool"]["busy"] == 0, 120)
        before = client.get("/health").json()["pool"]
        s = _send(server.url, "/render", heavy_scene(12.0))  # seconds of work, in the budget
        wait_ready(lambda: client.get("/health").json()["pool"]["busy"] == 1, 30)
        time.sleep(0.5)
        assert client.get("/health").json()["pool"]["busy"] == 1  # rendering
        s.close()
        t0 = time.monotonic()
        wait_ready(lambda: client.get("/health").json()["pool"]["busy"] == 0, 30)
        assert time.monotonic() - t0 < 2.0
        after = client.get("/health").json()["pool"]
        assert after["replaced"] == before["replaced"], (before, after)  # stopped, not killed
        assert client.post("/render", json=pluck_scene(0.05)).status_code == 200


# ---- heavy renders leave a worker to small ones --------------------------------------------------

def test_two_heavy_renders_do_not_starve_a_small_one(harness) -> None:
    h = harness  # two workers: heavy renders may hold one

    async def run():
        heavy = [asyncio.ensure_future(h.client.post("/render", json=heavy_scene(3.0 + i * 0.01)))
                 for i in range(2)]
        await asyncio.sleep(0.3)
        waits = []
        for _ in range(5):
            t0 = time.monotonic()
            r = await h.client.post("/render", json=pluck_scene(0.05))
            waits.append((r.status_code, time.monotonic() - t0))
        heavy_status = [(await x).status_code for x in heavy]
        return waits, heavy_status, h.pool.status()

    waits, heavy_status, _ = h.run(run(), timeout=120)
    assert heavy_status == [200, 200]
    assert all(code == 200 for code, _ in waits), waits
    assert max(t for _, t in waits) < 2.0, waits  # not behind a 12-s render


# ---- liveness and readiness; a hung worker is replaced ------------------------------------------

@pytest.fixture(scope="module")
def beat_harness(tmp_path_factory: pytest.TempPathFactory) -> Iterator[AppHarness]:
    h = AppHarness(Settings(workers=2, heartbeat_s=0.25, heartbeat_timeout_s=2.0,
                            data_dir=str(tmp_path_factory.mktemp("hung-data")))).start()
    yield h
    h.stop()


def _poll(h: AppHarness, until, timeout: float) -> list[tuple[int, int]]:
    """(/health, /health/ready) status codes every 50 ms until ``until()`` or the timeout."""
    seen = []
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        seen.append((h.get("/health").status_code, h.get("/health/ready").status_code))
        if until():
            return seen
        time.sleep(0.05)
    raise TimeoutError(f"not within {timeout} s: {seen[-5:]}")


@pytest.mark.parametrize("stopped", [1, 2])
def test_a_stopped_worker_is_not_ready_and_is_replaced(beat_harness, stopped) -> None:
    h = beat_harness
    wait_ready(lambda: h.pool.status()["workers_ready"] == 2, 120)
    hung = h.pool.status()["hung"]
    victims = h.pool.pids()[:stopped]
    t0 = time.monotonic()
    for pid in victims:
        os.kill(pid, signal.SIGSTOP)
    try:
        # not counted ready within a few heartbeats
        seen = _poll(h, lambda: h.pool.status()["workers_ready"] == 2 - stopped, 2.0)
        assert time.monotonic() - t0 < 1.5
        # killed within heartbeat_timeout_s (+ one watchdog period), then replaced
        seen += _poll(h, lambda: all(p not in h.pool.pids() for p in victims), 4.0)
        assert time.monotonic() - t0 < 2.0 + 0.5 + 0.5
        assert h.pool.status()["hung"] == hung + stopped
        seen += _poll(h, lambda: h.pool.status()["workers_ready"] == 2, 120)
    finally:
        for pid in victims:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass
    flaps = [(i, x) for i, x in enumerate(seen) if x[0] != 200]
    assert not flaps, (flaps, len(seen), h.pool.status())  # /health never flapped
    readies = {ready for _, ready in seen}
    assert readies == ({200} if stopped == 1 else {200, 503}), seen
    assert h.get("/health/live").status_code == 200
    r = h.post("/render", json=pluck_scene(0.05))
    assert r.status_code == 200


def test_live_and_ready_apart_during_start_up(tmp_path: Path) -> None:
    h = AppHarness(Settings(workers=1, data_dir=str(tmp_path / "data")))
    h.thread.start()
    h.run(h._startup())
    try:
        assert h.get("/health/live").status_code == 200
        first = h.get("/health/ready")
        assert first.status_code == 503 and first.json()["ready"] is False
        wait_ready(lambda: h.get("/health/ready").status_code == 200, 120)
        assert h.get("/health").status_code == 200
    finally:
        h.stop()


def test_stream_bytes_equal_render_bytes_for_random_scenes(client) -> None:
    # the engine-level property (tests/engine/test_stream_equals_render.py), here over HTTP for a
    # few scenes whose strings decay below the skip level part-way
    for i, rate in enumerate((22050, 48000, 96000)):
        scene = {"duration": 0.6, "sample_rate": rate, "quality": ("draft", "standard", "high")[i],
                 "output": {"normalize": False, "subtype": ("PCM_16", "PCM_24", "FLOAT")[i]},
                 "events": [{"type": "pluck", "time": 0.01, "string": 5, "force": 1e-7},
                            {"type": "tap", "time": 0.0, "string": 2, "fret": 9,
                             "velocity": 4e-5}]}
        a = client.post("/render", json=scene)
        b = client.post("/render/stream", json=scene)
        assert a.status_code == b.status_code == 200
        assert same_bytes(a.content, b.content), i
