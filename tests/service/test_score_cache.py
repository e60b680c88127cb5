"""The score cache (``service.score_cache``): a file read again with the same importer options is
answered without a worker, with the scene a worker would give; a request the kept scene does not
answer (a shorter ``max_seconds``, a lower event limit, other options) goes to a worker.  Over
real HTTP (uvicorn), counted by ``guitar_score_imports_total``."""

from __future__ import annotations

import json
import re
from typing import Any

import httpx
import pytest
from svc_helpers import brief

from service.score_cache import ScoreCache
from tests.score_files import small_gp5

# ---- the cache alone ------------------------------------------------------------------------


def _meta(duration: float, events: int) -> dict[str, Any]:
    return {"warnings": ["w"], "duration": duration, "events": events}


def test_an_entry_answers_only_requests_it_is_the_answer_to() -> None:
    cache = ScoreCache(10_000)
    key = cache.key(b"file", "a.gp5", {"tracks": [1]})
    assert cache.key(b"file", "a.gp5", {"tracks": [1], "max_seconds": 9.0}) == key
    assert cache.key(b"file", "a.gp5", {"tracks": [2]}) != key
    assert cache.key(b"file", "b.gp5", {"tracks": [1]}) != key
    assert cache.key(b"filf", "a.gp5", {"tracks": [1]}) != key
    cache.put(key, {"tracks": [1]}, b"{}", _meta(20.0, 100))
    assert cache.get(key, {"tracks": [1]}, 100).warnings == ("w",)
    assert cache.get(key, {"max_seconds": 20.0}, 100) is not None  # the cut leaves it as it is
    assert cache.get(key, {"max_seconds": 19.9}, 100) is None  # the worker would cut it
    assert cache.get(key, {}, 99) is None  # the worker refuses it, in its own words
    assert (cache.hits, cache.misses) == (2, 2)


def test_a_cut_import_is_not_kept() -> None:
    cache = ScoreCache(10_000)
    cut = cache.key(b"x", "x.mid", {"max_seconds": 5.0})
    cache.put(cut, {"max_seconds": 5.0}, b"{}", _meta(5.0, 3))  # as long as the cut: cut
    assert len(cache) == 0
    cache.put(cut, {"max_seconds": 5.0}, b"{}", _meta(4.0, 3))  # shorter: the whole file
    assert cache.get(cut, {}, 10) is not None


def test_the_least_lately_used_go_first_and_nothing_is_kept_at_zero() -> None:
    cache = ScoreCache(3000)
    keys = [cache.key(bytes([i]), "s.mid", {}) for i in range(4)]
    for k in keys[:2]:
        cache.put(k, {}, b"x" * 1000, _meta(1.0, 1))
    assert cache.get(keys[0], {}, 1) is not None  # keys[1] is now the least lately used
    cache.put(keys[2], {}, b"x" * 1000, _meta(1.0, 1))
    cache.put(keys[3], {}, b"x" * 1000, _meta(1.0, 1))
    assert [cache.get(k, {}, 1) is not None for k in keys] == [True, False, True, True]
    cache.put(keys[1], {}, b"x" * 1600, _meta(1.0, 1))  # over half the cache: not kept
    assert cache.get(keys[1], {}, 1) is None
    off = ScoreCache(0)
    off.put(keys[0], {}, b"{}", _meta(1.0, 1))
    assert off.get(keys[0], {}, 1) is None


# ---- over HTTP --------------------------------------------------------------------------------


def _imports(server: Any) -> dict[str, float]:
    text = httpx.get(server.url + "/metrics", timeout=10).text
    return {m[0]: float(m[1]) for m in
            re.findall(r'^guitar_score_imports_total\{cache="(\w+)"\} (\S+)$', text, re.M)}


def _post(server: Any, path: str, data: bytes, **form: Any) -> httpx.Response:
    return httpx.post(server.url + path, files={"file": ("cached.gp5", data)},
                      data={k: json.dumps(v) for k, v in form.items()}, timeout=120)


def test_a_score_read_then_played_is_imported_once(server: Any) -> None:
    song = small_gp5(notes=((1, 3), (2, 5), (3, 7), (4, 2), (5, 9)), tracks=1)  # this test's own
    before = _imports(server)
    first = _post(server, "/score/scene", song, options={"quality": "draft"})
    assert first.status_code == 200, brief(first)
    again = _post(server, "/score/scene", song, options={"quality": "draft"})
    assert again.status_code == 200, brief(again)
    assert again.json() == first.json()
    after = _imports(server)
    assert (after["hit"] - before["hit"], after["miss"] - before["miss"]) == (1, 1)

    # the page's Play: the same file and options as a job (which adds its own max_seconds, longer
    # than the song): no import; the job's scene is the one read
    r = _post(server, "/jobs", song, options={"quality": "draft"},
              output={"format": "wav", "normalize": False})
    assert r.status_code == 202, brief(r)
    assert r.json()["duration"] == pytest.approx(first.json()["duration"])
    assert _imports(server)["hit"] - after["hit"] == 1
    httpx.delete(f"{server.url}/jobs/{r.json()['id']}", timeout=10)

    # a shorter max_seconds: a worker cuts it
    cut = _post(server, "/score/scene", song, options={"quality": "draft", "max_seconds": 0.7})
    assert cut.status_code == 200 and cut.json()["duration"] == pytest.approx(0.7), brief(cut)
    assert _imports(server)["miss"] - after["miss"] == 1
