"""Refusals stay short (a few KB) whatever they refuse, over a real uvicorn process: a score that
becomes 20,000 events and more is refused by the worker in one line, and a body of many invalid
fields lists the first few and a count, each echoed input short."""

from __future__ import annotations

import json
from collections.abc import Iterator

import httpx
import pytest
from conftest import UvicornServer
from svc_helpers import brief

from tests.score_files import dense_midi


@pytest.fixture(scope="module")
def slow_import_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[UvicornServer]:
    # the 30,000-note import takes 6 s on an idle core: time enough on a loaded machine
    s = UvicornServer(tmp_path_factory.mktemp("refusals"), {
        "GUITAR_WORKERS": "1", "GUITAR_SCORE_IMPORT_TIME_LIMIT_S": "120"}).start()
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
