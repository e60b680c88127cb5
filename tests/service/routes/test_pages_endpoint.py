"""GET / (the demo page and its assets), GET /docs and GET /openapi.json."""

from __future__ import annotations

import re

import pytest
from svc_helpers import brief

import engine


def test_demo_page_and_assets(harness) -> None:
    r = harness.get("/")
    assert r.status_code == 200 and r.headers["content-type"].startswith("text/html")
    html = r.text
    assert 'id="spectrogram"' in html and "<audio" in html
    assets = re.findall(r'(?:src|href)="(/static/[^"]+)"', html)
    assert {"/static/app.js", "/static/fft.js", "/static/style.css"} <= set(assets)
    for path in assets:
        assert harness.get(path).status_code == 200, path
    assert not re.search(r'(?:src|href)="(?:https?:)?//', html)  # offline: no CDN


def test_docs(harness) -> None:
    r = harness.get("/docs")
    assert r.status_code == 200 and "openapi.json" in r.text


@pytest.fixture(scope="module")
def openapi(harness) -> dict:
    return harness.get("/openapi.json").json()


def test_openapi_request_body_is_the_engine_scene(openapi: dict) -> None:
    for path in ("/render", "/render/stream"):
        body = openapi["paths"][path]["post"]["requestBody"]["content"]["application/json"]
        assert body["schema"]["$ref"].endswith("/Scene")
    assert set(engine.Scene.model_fields) <= set(openapi["components"]["schemas"]["Scene"]
                                                   ["properties"])


def test_openapi_documents_error_statuses(openapi: dict) -> None:
    responses = openapi["paths"]["/render"]["post"]["responses"]
    assert {"200", "413", "422", "502", "503", "504"} <= set(responses)
    assert {"audio/wav", "audio/flac", "audio/ogg"} <= set(responses["200"]["content"])


def test_a_worked_example_per_event_type_and_each_renders(harness, openapi: dict) -> None:
    examples = openapi["paths"]["/render"]["post"]["requestBody"]["content"][
        "application/json"]["examples"]
    tags = set(openapi["components"]["schemas"]["Scene"]["properties"]["events"]["items"]
               ["discriminator"]["mapping"])
    assert tags >= {"pluck", "fret", "tap"}
    covered = {e["type"] for ex in examples.values() for e in ex["value"].get("events", [])}
    assert tags <= covered
    for name, ex in examples.items():
        r = harness.post("/render", json=ex["value"])
        assert r.status_code == 200, (name, brief(r))
