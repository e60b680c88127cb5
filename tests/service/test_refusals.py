"""Refusals stay short (a few KB) whatever they refuse, over a real uvicorn process: a score that
becomes 20,000 events and more is refused by the worker in one line, a body of many invalid
fields lists the first few and a count, each echoed input short, and so on every path that
refuses (the render routes, jobs, labels, score forms, oversized and malformed bodies)."""

from __future__ import annotations

import json
from collections.abc import Iterator

import httpx
import pytest
from conftest import UvicornServer
from svc_helpers import brief

from engine.testing.scores import gp5_song
from tests.score_files import dense_midi, small_midi


@pytest.fixture(scope="module")
def slow_import_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[UvicornServer]:
    # the 30,000-note import takes 6 s on an idle core: time enough on a loaded machine
    tmp = tmp_path_factory.mktemp("refusals")
    s = UvicornServer(tmp, {
        "GUITAR_WORKERS": "1", "GUITAR_SCORE_IMPORT_TIME_LIMIT_S": "120",
        "GUITAR_DATA_DIR": str(tmp / "data")}).start()
    yield s
    s.stop()


def test_a_score_of_too_many_events_is_refused_in_a_few_kb(slow_import_server) -> None:
    """30,000 notes in 31 s, the first 30 s asked for: a scene of over 20,000 events, 1.5 MB.  It
    was refused with the whole list echoed (a 2.26 MB body, serialised on the event loop); now the
    worker refuses it in one line naming the limit and the way out."""
    r = httpx.post(slow_import_server.url + "/render/score", timeout=180,
                   files={"file": ("dense.mid", dense_midi(30000), "audio/midi")},
                   data={"options": json.dumps({"max_seconds": 30})})
    assert r.status_code == 422, brief(r)
    assert len(r.content) < 4096, len(r.content)
    (item,) = r.json()["detail"]
    assert item["field"] == "file", item
    for words in ("dense.mid", "GUITAR_MAX_SCORE_EVENTS", "options.max_seconds"):
        assert words in item["message"], item["message"]
    # the same score as a job: refused by the worker against the job's own limit
    r = httpx.post(slow_import_server.url + "/jobs", timeout=180,
                   files={"file": ("dense.mid", dense_midi(30000), "audio/midi")},
                   data={"options": json.dumps({"max_seconds": 30})})
    assert r.status_code == 422 and len(r.content) < 4096, (r.status_code, len(r.content))
    assert "GUITAR_JOB_MAX_EVENTS" in r.json()["detail"][0]["message"], r.text


def test_many_invalid_fields_are_listed_briefly(slow_import_server) -> None:
    """Every one of 400 events wrong, each with a long string: the first 20 errors and a count of
    the rest, each input echoed only while it is short."""
    events = [{"type": "pluck", "time": 0.001 * i, "string": 1, "force": 99.0,
               "style": "x" * 300} for i in range(400)]
    r = httpx.post(slow_import_server.url + "/render", json={"duration": 1.0, "events": events},
                   timeout=60)
    assert r.status_code == 422, brief(r)
    assert len(r.content) < 16384, len(r.content)
    detail = r.json()["detail"]
    assert len(detail) == 21 and detail[-1]["message"].startswith("and "), detail[-1]
    assert all(len(json.dumps(d.get("input"))) <= 210 for d in detail), detail[:3]


def _many_bad_events() -> dict:
    return {"duration": 1.0, "events": [
        {"type": "pluck", "time": 0.001 * i, "string": 1, "force": 99.0, "style": "x" * 300}
        for i in range(400)]}


_TRACKS = json.dumps({"tracks": list(range(1, 20001))})  # a list of 20,000 where 64 are allowed
_SCORE = {"file": ("s.mid", small_midi(), "audio/midi")}


@pytest.mark.parametrize(("method", "path", "body", "field"), [
    ("json", "/render/stream", _many_bad_events(), "events[0].force"),
    ("json", "/jobs", _many_bad_events(), "events[0].force"),
    ("json", "/scene/labels", _many_bad_events(), "events[0].force"),
    ("form", "/render/score", {"options": _TRACKS}, "options.tracks"),
    ("form", "/score/scene", {"options": _TRACKS}, "options.tracks"),
    ("form", "/score/labels", {"options": _TRACKS}, "options.tracks"),
    ("form", "/jobs", {"options": _TRACKS}, "options.tracks"),
    ("form", "/render/score", {"options": json.dumps({"presets": "x" * 100_000})},
     "options.presets"),
    ("raw", "/render", b'{"duration": 1.0, "events": [' + b'{"type": "pluck"}, ' * 12_000,
     ""),
    ("raw", "/render", b'{"duration": 1.0, "events": []}' + b" " * 300_000, None),
])
def test_every_refusal_is_short_and_names_its_field(slow_import_server, method, path, body,
                                                    field) -> None:
    """Each path that refuses: a body of many errors, an echoed list of 20,000 items, a preset name of
    100 KB, JSON cut short after 200 KB, a body over the size limit (413): the answer stays a few
    KB, naming the field."""
    url = slow_import_server.url + path
    if method == "json":
        r = httpx.post(url, json=body, timeout=120)
    elif method == "form":
        r = httpx.post(url, files=_SCORE, data=body, timeout=120)
    else:
        r = httpx.post(url, content=body, headers={"content-type": "application/json"},
                       timeout=120)
    assert 400 <= r.status_code < 500, brief(r)
    assert len(r.content) < (16384 if method == "json" else 4096), (len(r.content), r.text[:300])
    if field is None:
        assert r.status_code == 413 and "GUITAR_MAX_BODY_BYTES" in r.text, brief(r)
        return
    detail = r.json()["detail"]
    assert detail[0]["field"] == field, detail[0]
    assert all(len(json.dumps(d.get("input"))) <= 210 for d in detail), detail[:2]


def test_a_score_over_the_cost_budget_names_the_option_that_fits(slow_import_server) -> None:
    """A score's render over GUITAR_MAX_RENDER_S named ``duration``, a field its client never
    sent; the way out for a score is ``options.max_seconds``, which the refusal now names, with
    the longest that fits."""
    notes = [(1, 5), (2, 5), (3, 5), (1, 7), (2, 7), (3, 7), (1, 8), (2, 8)] * 2
    r = httpx.post(slow_import_server.url + "/render/score", timeout=180,
                   files={"file": ("s.gp5", gp5_song(notes, tempo=40))},  # 25.5 s
                   data={"options": json.dumps({"sample_rate": 96000, "quality": "high"})})
    assert r.status_code == 422 and len(r.content) < 4096, brief(r)
    (d,) = r.json()["detail"]
    assert d["field"] == "options.max_seconds", d
    assert "GUITAR_MAX_RENDER_S" in d["message"] and "options.max_seconds" in d["message"], d
    assert 0 < d["ctx"]["le"] < 25.5, d
