"""The demo page's ready examples (``static/examples.json``): they cover every event type, pluck
style and preset, and each one renders (in-process app, both workers at once)."""

from __future__ import annotations

import asyncio
import json
from typing import Any, get_args

import httpx
import numpy as np
import pytest
from conftest import ROOT
from svc_helpers import brief, decode

import engine
from engine.scene import Event

EXAMPLES_FILE = ROOT / "static" / "examples.json"
EXAMPLES: dict[str, Any] = json.loads(EXAMPLES_FILE.read_text())
BY_ID = {ex["id"]: ex for ex in EXAMPLES["examples"]}
EVENT_TYPES = {m.model_fields["type"].default for m in get_args(get_args(Event)[0])}
PLUCK_STYLES = set(get_args(engine.scene.PluckStyle))


def test_examples_file_is_well_formed() -> None:
    assert len(BY_ID) == len(EXAMPLES["examples"]), "example ids must be unique"
    assert EXAMPLES["default"] in BY_ID
    for ex in EXAMPLES["examples"]:
        assert set(ex) == {"id", "label", "description", "scene"}, ex["id"]
        assert ex["label"] and ex["description"], ex["id"]


def test_examples_cover_every_event_type_style_and_preset() -> None:
    events = [e for ex in BY_ID.values() for e in ex["scene"]["events"]]
    assert {e["type"] for e in events} == EVENT_TYPES
    assert {e.get("style", "finger") for e in events if e["type"] in ("pluck", "strum")} \
        == PLUCK_STYLES
    assert {ex["scene"]["guitar"]["preset"] for ex in BY_ID.values()} == set(engine.PRESETS)


@pytest.mark.parametrize("name", BY_ID)
def test_example_is_a_valid_short_scene(name: str) -> None:
    scene = engine.parse_scene(BY_ID[name]["scene"])
    assert scene.duration <= 3.0 and scene.quality in ("draft", "standard")


@pytest.fixture(scope="module")
def rendered(harness) -> dict[str, httpx.Response]:
    """Every example POSTed to /render, one per worker at a time (more would fill the queue)."""
    async def all_of_them() -> list[httpx.Response]:
        slots = asyncio.Semaphore(harness.settings.workers)

        async def post(ex: dict[str, Any]) -> httpx.Response:
            assert harness.client is not None
            async with slots:
                return await harness.client.post("/render", json=ex["scene"])

        return await asyncio.gather(*(post(ex) for ex in BY_ID.values()))

    return dict(zip(BY_ID, harness.run(all_of_them(), timeout=180.0), strict=True))


@pytest.mark.parametrize("name", BY_ID)
def test_example_renders(rendered: dict[str, httpx.Response], name: str) -> None:
    r = rendered[name]
    assert r.status_code == 200, brief(r)
    assert r.headers["content-type"] == "audio/wav"
    scene = BY_ID[name]["scene"]
    x, rate, info = decode(r.content)
    channels = scene.get("output", {}).get("channels", 1)
    assert (info.format, rate, info.channels) == ("WAV", 44100, channels)
    assert info.frames == round(scene["duration"] * rate)
    assert np.all(np.isfinite(x))
    assert np.max(np.abs(x)) > 0.5  # normalised to -1 dBFS: not silent
