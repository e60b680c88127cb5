"""Request ids and the body size limit (in-process; the JSON access log is checked against a real
uvicorn process in test_uvicorn_process.py)."""

from __future__ import annotations

import json
import logging
import re

import pytest
from svc_helpers import pluck_scene

from service.logs import JsonFormatter


def test_request_id_is_echoed(harness) -> None:
    r = harness.get("/health", headers={"X-Request-ID": "abc.DEF-123"})
    assert r.headers["x-request-id"] == "abc.DEF-123"


@pytest.mark.parametrize("bad", ["x" * 200, "has space", "new\tline", ""])
def test_unsafe_request_id_is_replaced(harness, bad: str) -> None:
    r = harness.get("/health", headers={"X-Request-ID": bad})
    rid = r.headers["x-request-id"]
    assert rid != bad and re.fullmatch("[0-9a-f]{32}", rid), rid  # a fresh uuid4, as hex


def test_request_ids_differ(harness) -> None:
    ids = {harness.get("/health").headers["x-request-id"] for _ in range(5)}
    assert len(ids) == 5


def test_errors_carry_a_request_id_too(harness) -> None:
    r = harness.post("/render", content=b"x" * 300_000, headers={"content-type": "application/json"})
    assert r.status_code == 413 and len(r.headers["x-request-id"]) == 32


def test_body_just_under_the_limit_is_read(harness) -> None:
    scene = pluck_scene(0.05)
    body = json.dumps(scene)[:-1] + ', "output": {"format": "wav"}' + " " * 200_000 + "}"
    assert len(body) < harness.settings.max_body_bytes
    assert harness.post("/render", content=body,
                        headers={"content-type": "application/json"}).status_code == 200


def test_json_formatter_writes_one_object_per_line() -> None:
    record = logging.LogRecord("service.access", logging.INFO, __file__, 1, "request", None, None)
    record.fields = {"request_id": "r1", "status": 200, "realtime_factor": 12.5}
    line = JsonFormatter().format(record)
    assert "\n" not in line
    obj = json.loads(line)
    assert obj["msg"] == "request" and obj["request_id"] == "r1" and obj["level"] == "info"
    assert obj["ts"].endswith("Z")
