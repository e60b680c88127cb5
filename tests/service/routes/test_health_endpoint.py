"""GET /health and GET /limits."""

from __future__ import annotations

import time

from conftest import AppHarness

from service.config import Settings


def test_health_ok_when_workers_are_warm(harness) -> None:
    r = harness.get("/health")
    assert r.status_code == 200
    body = r.json()
    assert body["status"] == "ok" and body["ready"] is True
    assert body["pool"]["workers_ready"] == body["pool"]["workers"] == 2


def test_health_is_503_until_every_worker_has_warmed_up() -> None:
    # Right after start-up the worker is still spawning and warming up (a second at least, with
    # a warm numba cache): /health must say 'starting' until it reports ready.
    h = AppHarness(Settings(workers=1, warmup=True))
    h.thread.start()
    h.run(h._startup())
    try:
        first = h.get("/health")
        states = [first.status_code]
        deadline = time.monotonic() + 120
        while states[-1] != 200 and time.monotonic() < deadline:
            time.sleep(0.05)
            states.append(h.get("/health").status_code)
        assert first.status_code == 503 and first.json()["status"] == "starting"
        assert first.json()["ready"] is False
        assert states[-1] == 200
    finally:
        h.stop()


def test_limits_reflect_settings(harness) -> None:
    body = harness.get("/limits").json()
    s = harness.settings
    assert body["max_duration_s"] == s.max_duration_s == 30.0
    assert body["max_events"] == s.max_events and body["max_body_bytes"] == s.max_body_bytes
    assert body["stream_formats"] == ["wav"]
