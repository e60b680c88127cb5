"""The service as deployed: ``uvicorn service.app:app`` in its own process, over real HTTP on
127.0.0.1 — endpoints, streaming as it is computed, client disconnects, access logs."""

from __future__ import annotations

import json
import re
import time
from collections.abc import Iterator
from concurrent.futures import ThreadPoolExecutor

import httpx
import numpy as np
import pytest
from conftest import UvicornServer
from svc_helpers import chord_scene, decode, heavy_scene, pluck_scene, same_bytes


@pytest.fixture(scope="module")
def client(server: UvicornServer) -> Iterator[httpx.Client]:
    with httpx.Client(base_url=server.url, timeout=60.0) as c:
        yield c


@pytest.fixture(scope="module")
def strict_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[UvicornServer]:
    """One worker and a 0.5 s time limit, configured through the environment."""
    s = UvicornServer(tmp_path_factory.mktemp("strict"), {
        "GUITAR_WORKERS": "1", "GUITAR_TIME_LIMIT_BASE_S": "0.5",
        "GUITAR_TIME_LIMIT_PER_AUDIO_S": "0"}).start()
    yield s
    s.stop()


def test_every_endpoint(client: httpx.Client) -> None:
    assert client.get("/health").json()["ready"] is True
    assert "<canvas" in client.get("/").text
    assert client.get("/presets").json()["default"] == "steel-acoustic"
    assert client.get("/limits").json()["max_duration_s"] == 30.0
    assert "swagger" in client.get("/docs").text.lower()
    assert "/render/stream" in client.get("/openapi.json").json()["paths"]
    r = client.post("/render", json=chord_scene(0.2))
    assert r.status_code == 200 and r.headers["content-type"] == "audio/wav"
    s = client.post("/render/stream", json=chord_scene(0.2, output={"normalize": False}))
    assert s.status_code == 200
    fixed = client.post("/render", json=chord_scene(0.2, output={"normalize": False}))
    assert same_bytes(s.content, fixed.content)


def test_stream_sends_bytes_before_the_render_is_done(client: httpx.Client) -> None:
    scene = heavy_scene(6.0)  # a second or more of work
    t0 = time.perf_counter()
    with client.stream("POST", "/render/stream", json=scene) as r:
        assert r.status_code == 200
        assert "chunked" not in r.headers.get("transfer-encoding", "")  # exact Content-Length
        it = r.iter_raw()
        first = next(it)
        t_first = time.perf_counter() - t0
        data = first + b"".join(it)
    total = time.perf_counter() - t0
    assert total > 1.0, "scene too light to tell streaming from buffering"
    assert t_first < total / 4, (t_first, total)
    x, rate, info = decode(data)
    assert (rate, len(x), info.subtype) == (96000, 576000, "PCM_16")
    assert np.max(np.abs(x)) > 0


def test_client_disconnect_stops_the_render(client: httpx.Client, server: UvicornServer) -> None:
    # 12 s of six strings at 96 kHz, quality high (inside the default cost budget): far longer to
    # render than the wait below.
    with httpx.Client(base_url=server.url, timeout=60.0) as other:
        with other.stream("POST", "/render/stream", json=heavy_scene(12.0)) as r:
            assert r.status_code == 200
            next(r.iter_raw())
            assert client.get("/health").json()["pool"]["busy"] == 1
        # leaving the block closes the connection
    t0 = time.monotonic()
    while client.get("/health").json()["pool"]["busy"] and time.monotonic() - t0 < 10:
        time.sleep(0.05)
    assert client.get("/health").json()["pool"]["busy"] == 0
    assert time.monotonic() - t0 < 3.0
    assert client.post("/render", json=pluck_scene(0.05)).status_code == 200


def test_concurrent_requests_over_http(server: UvicornServer) -> None:
    def one(i: int) -> int:
        path = "/render" if i % 2 else "/render/stream"
        return httpx.post(server.url + path, json=pluck_scene(0.2, string=1 + i % 6),
                          timeout=60).status_code

    with ThreadPoolExecutor(6) as ex:
        assert list(ex.map(one, range(6))) == [200] * 6


def test_request_id_and_json_access_log(client: httpx.Client, server: UvicornServer) -> None:
    t0 = time.perf_counter()
    r = client.post("/render", json=pluck_scene(0.3), headers={"X-Request-ID": "test-rid-42"})
    elapsed = time.perf_counter() - t0
    assert r.headers["x-request-id"] == "test-rid-42"
    # the server's own time: at least the render's, at most what the client waited
    m = re.fullmatch(r"app;dur=(\d+\.\d)", r.headers["server-timing"])
    assert m, r.headers["server-timing"]
    assert float(r.headers["x-render-seconds"]) <= float(m.group(1)) / 1000 <= elapsed
    generated = client.get("/health").headers["x-request-id"]
    assert re.fullmatch("[0-9a-f]{32}", generated), generated  # a fresh uuid4, as hex
    time.sleep(0.2)
    lines = [json.loads(x) for x in server.log_lines() if x.startswith("{")]
    line = next(x for x in lines if x.get("request_id") == "test-rid-42")
    assert line["logger"] == "service.access" and line["status"] == 200
    assert line["path"] == "/render" and line["audio_seconds"] == pytest.approx(0.3)
    assert line["render_seconds"] == pytest.approx(float(r.headers["x-render-seconds"]), abs=1e-3)
    assert line["realtime_factor"] == pytest.approx(0.3 / line["render_seconds"], rel=0.02)


def test_oversized_body_over_http(client: httpx.Client) -> None:
    r = client.post("/render", content=b"{" + b" " * 300_000 + b"}",
                    headers={"content-type": "application/json"})
    assert r.status_code == 413


def test_render_past_its_time_limit_over_http(strict_server: UvicornServer) -> None:
    r = httpx.post(strict_server.url + "/render", json=heavy_scene(6.0), timeout=60)
    assert r.status_code == 504


def test_stream_failing_mid_body_is_cut_short(strict_server: UvicornServer) -> None:
    # The header went out with the first block; the time limit strikes later.  The server must
    # close the connection so the client sees an incomplete body, never a truncated "success".
    with pytest.raises(httpx.RemoteProtocolError):
        httpx.post(strict_server.url + "/render/stream", json=heavy_scene(6.0), timeout=60)
    deadline = time.monotonic() + 30
    while httpx.get(strict_server.url + "/health").status_code != 200:
        assert time.monotonic() < deadline
        time.sleep(0.1)
    lines = [json.loads(x) for x in strict_server.log_lines() if x.startswith("{")]
    assert any(x.get("path") == "/render/stream" and "time limit" in x.get("error", "")
               for x in lines)
    ok = httpx.post(strict_server.url + "/render/stream", json=pluck_scene(0.05), timeout=60)
    assert ok.status_code == 200


def test_the_render_workers_keep_what_their_warm_up_made_out_of_the_collectors_sight(
        server: UvicornServer) -> None:
    """A warmed render worker holds tens of thousands of objects (the engine, numba's kernels,
    the labels' libraries) that live as long as it does; each full collection a render's
    allocations trigger would walk them all in that render's time.  The worker freezes them after
    its warm-up (``gc.freeze``) and its ready line says how many."""
    lines = [json.loads(x) for x in server.log_lines() if x.startswith("{")]
    ready = [x for x in lines if x.get("msg") == "worker ready"]
    assert len(ready) >= 2 and all(x["gc_frozen"] > 100_000 for x in ready), ready
