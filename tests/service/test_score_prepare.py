"""A score's scene is made ready in a worker (``service.worker``, job ``score`` with ``prepare``):
imported, its options and output fields set, validated and measured there.  The API process,
whose event loop relays every live block, never parses, validates or dumps the scene: on a
whole song each of those took tens of milliseconds of that loop."""

from __future__ import annotations

import json
from collections.abc import Iterator
from typing import Any

import pytest
from conftest import AppHarness

import engine
from engine.testing.scores import gp5_song
from service.config import Settings
from service.errors import MAX_ERRORS, _detail, portable_errors

SONG = gp5_song([(3, 0), (2, 1), (1, 0), (2, 3)] * 4)  # 16 quarter notes at 120 bpm: 8 s


@pytest.fixture(scope="module")
def app(tmp_path_factory: pytest.TempPathFactory) -> Iterator[AppHarness]:
    h = AppHarness(Settings(workers=1, data_dir=str(tmp_path_factory.mktemp("prep")))).start()
    yield h
    h.stop()


@pytest.fixture
def validations(monkeypatch: pytest.MonkeyPatch) -> list[Any]:
    """Every scene this process validates from a dict or JSON (the workers are processes of
    their own: theirs are not seen)."""
    seen: list[Any] = []
    plain, from_json = engine.Scene.model_validate.__func__, engine.Scene.model_validate_json.__func__

    def model_validate(cls, obj, *args, **kwargs):
        seen.append(obj)
        return plain(cls, obj, *args, **kwargs)

    def model_validate_json(cls, data, *args, **kwargs):
        seen.append(data)
        return from_json(cls, data, *args, **kwargs)

    monkeypatch.setattr(engine.Scene, "model_validate", classmethod(model_validate))
    monkeypatch.setattr(engine.Scene, "model_validate_json", classmethod(model_validate_json))
    return seen


def _form(options: dict[str, Any] | None = None, output: Any = None) -> dict[str, Any]:
    data = {"options": json.dumps(options or {})}
    if output is not None:
        data["output"] = output if isinstance(output, str) else json.dumps(output)
    return {"files": {"file": ("song.gp5", SONG)}, "data": data}


def test_every_score_path_leaves_the_scene_to_a_worker(app: AppHarness,
                                                       validations: list[Any]) -> None:
    scene = app.post("/score/scene", **_form({"quality": "draft"}))
    assert scene.status_code == 200, scene.text
    assert scene.json()["quality"] == "draft" and scene.json()["duration"] >= 8.0
    labels = app.post("/score/labels", **_form())
    assert labels.status_code == 200 and labels.json()["annotations"], labels.text
    audio = app.post("/render/score", **_form({"max_seconds": 1.0, "quality": "draft"}, "flac"))
    assert audio.status_code == 200 and audio.headers["content-type"] == "audio/flac", audio.text
    job = app.post("/jobs", **_form({"quality": "draft"}, {"format": "wav"}))
    assert job.status_code == 202, job.text
    assert job.json()["duration"] == pytest.approx(scene.json()["duration"])
    assert validations == []


def test_a_score_s_scene_invalid_after_its_options_is_refused_at_the_fields(app: AppHarness) -> None:
    """The worker's validation errors come back as pydantic's, their fields the client's."""
    r = app.post("/render/score", **_form({"max_seconds": 1.0}, {"channels": 7}))
    assert r.status_code == 422
    assert [d["field"] for d in r.json()["detail"]] == ["output.channels"]
    r = app.post("/jobs", **_form(None, {"format": "mp4"}))
    assert r.status_code == 422
    assert [d["field"] for d in r.json()["detail"]] == ["output.format"]


def test_errors_sent_from_a_worker_keep_their_count_and_lose_their_bulk() -> None:
    errors = [{"type": "value_error", "loc": ("tracks", 0, "events", i), "msg": "bad",
               "input": {"notes": list(range(10_000))}} for i in range(MAX_ERRORS + 7)]
    sent = json.loads(json.dumps(portable_errors(errors)))
    assert len(sent) == MAX_ERRORS + 1 and len(json.dumps(sent)) < 20_000
    assert sent[-1]["msg"] == "and 7 more errors"
    shown = _detail(sent)
    assert len(shown) == MAX_ERRORS + 1 and shown[-1]["msg"] == "and 7 more errors"
    assert _detail(errors)[-1] == shown[-1]  # as if the errors had been raised here
