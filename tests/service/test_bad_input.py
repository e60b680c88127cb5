"""Bad input of every kind: a 4xx whose detail names the field (and the allowed range), never 5xx."""

from __future__ import annotations

import copy
import json
from typing import Any

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from svc_helpers import brief, decode, pluck_scene

GOOD = pluck_scene(0.1)


def with_event(**changes: Any) -> dict[str, Any]:
    scene = copy.deepcopy(GOOD)
    scene["events"][0].update(changes)
    return scene


def with_(path: str, value: Any) -> dict[str, Any]:
    scene = copy.deepcopy(GOOD)
    *parents, last = path.split(".")
    node = scene
    for p in parents:
        node = node.setdefault(p, {})
    node[last] = value
    return scene


# name -> (scene, expected field, words the message must contain)
SCENE_CASES: dict[str, tuple[dict[str, Any], str, list[str]]] = {
    "duration wrong type": (with_("duration", "long"), "duration", ["number"]),
    "duration missing": ({"events": []}, "duration", ["required"]),
    "duration zero": (with_("duration", 0), "duration", ["greater than 0"]),
    "duration over the service limit": (with_("duration", 31.0), "duration",
                                        ["less than or equal to 30", "GUITAR_MAX_DURATION_S"]),
    "sample rate too low": (with_("sample_rate", 8000), "sample_rate", ["22050"]),
    "sample rate too high": (with_("sample_rate", 192000), "sample_rate", ["96000"]),
    "sample rate not an integer": (with_("sample_rate", 44100.5), "sample_rate", ["integer"]),
    "unknown preset": (with_("guitar.preset", "banjo"), "guitar.preset",
                       ["banjo", "steel-acoustic"]),
    "unknown event type": (with_event(type="kazoo"), "events[0]", ["kazoo", "pluck"]),
    "string outside the preset": (with_event(string=7), "events[0].string", ["7", "1..6"]),
    "string zero": (with_event(string=0), "events[0].string", ["greater than or equal to 1"]),
    "string wrong type": (with_event(string="high"), "events[0].string", ["integer"]),
    "event time negative": (with_event(time=-0.1), "events[0].time", ["greater than or equal"]),
    "event time after the scene": (with_event(time=0.1), "events[0].time", ["0 <= time < 0.1"]),
    "negative force": (with_event(force=-1.0), "events[0].force", ["greater than 0"]),
    "force too large": (with_event(force=100.0), "events[0].force", ["less than or equal to 20"]),
    "position outside the string": (with_event(position=1.5), "events[0].position",
                                    ["less than or equal to 0.98"]),
    "fret beyond the neck": ({"duration": 0.1, "events": [
        {"type": "fret", "time": 0.0, "string": 1, "fret": 22}]}, "events[0].fret", ["0..20"]),
    "fret beyond any neck": ({"duration": 0.1, "events": [
        {"type": "fret", "time": 0.0, "string": 1, "fret": 30}]}, "events[0].fret",
        ["less than or equal to 24"]),
    "release before the event": ({"duration": 0.5, "events": [
        {"type": "fret", "time": 0.2, "string": 1, "fret": 2, "release": 0.1}]},
        "events[0].release", ["after"]),
    "missing event field": ({"duration": 0.1, "events": [{"type": "pluck", "time": 0.0}]},
                            "events[0].string", ["required"]),
    "events not a list": (with_("events", {"type": "pluck"}), "events", ["list"]),
    "too many events": ({"duration": 0.1, "events": [
        {"type": "pluck", "time": 0.0, "string": 1}] * 501}, "events",
        ["at most 500", "GUITAR_MAX_EVENTS"]),
    "unknown field": (with_("loudness", 11), "loudness", ["not permitted"]),
    "unknown output format": (with_("output.format", "mp3"), "output.format", ["wav", "flac"]),
    "unknown wav subtype": (with_("output.subtype", "PCM_8"), "output.subtype", ["PCM_16"]),
    "normalize not a boolean": (with_("output.normalize", "maybe"), "output.normalize",
                                ["boolean"]),
    "tuning of too many strings": (with_("guitar.tuning", ["E2"] * 13), "guitar.tuning",
                                   ["at most 12"]),
    "not a note name": (with_("guitar.tuning", ["H9"] * 6), "guitar.tuning", ["H9"]),
    "quality unknown": (with_("quality", "ultra"), "quality", ["draft"]),
}


@pytest.mark.parametrize("name", sorted(SCENE_CASES))
@pytest.mark.parametrize("path", ["/render", "/render/stream"])
def test_bad_scene(harness, name: str, path: str) -> None:
    scene, field, words = SCENE_CASES[name]
    r = harness.post(path, json=scene)
    assert r.status_code == 422, (name, brief(r))
    detail = r.json()["detail"]
    assert field in [d["field"] for d in detail], detail
    text = " ".join(d["message"] for d in detail)
    assert field in text
    for word in words:
        assert word in text, (word, text)


RAW_CASES: dict[str, tuple[bytes, str, str]] = {
    # name -> (body, expected field, word in the message)
    "NaN token": (b'{"duration": NaN}', "duration", "NaN"),
    "Infinity token": (b'{"duration": 0.1, "events": [{"type": "pluck", "time": 0, '
                       b'"string": 1, "force": Infinity}]}', "events[0].force", "Infinity"),
    "-Infinity token": (b'{"duration": 0.1, "events": [{"type": "pluck", "time": -Infinity, '
                        b'"string": 1}]}', "events[0].time", "Infinity"),
    "NaN token in a string field": (b'{"duration": 0.1, "guitar": {"preset": NaN}}',
                                    "guitar.preset", "NaN"),
    "malformed JSON": (b'{"duration": 0.1,', "", "JSON decode error"),
    "not JSON at all": (b"duration=1", "", "JSON decode error"),
    "body is a list": (b"[1, 2]", "", "valid dictionary"),
    "empty body": (b"", "", "required"),
    "deeply nested JSON": (b"[" * 100_000 + b"]" * 100_000, "", "JSON"),
}


@pytest.mark.parametrize("name", sorted(RAW_CASES))
def test_bad_body(harness, name: str) -> None:
    body, field, word = RAW_CASES[name]
    r = harness.post("/render", content=body, headers={"content-type": "application/json"})
    assert 400 <= r.status_code < 500, (name, brief(r))
    detail = r.json()["detail"]
    assert isinstance(detail, list), detail
    assert field in [d["field"] for d in detail], detail
    assert any(word in d["message"] for d in detail), detail


def test_wrong_content_type(harness) -> None:
    r = harness.post("/render", content=json.dumps(GOOD), headers={"content-type": "text/plain"})
    assert r.status_code == 422


def test_oversized_body_by_content_length(harness) -> None:
    body = b'{"duration": 0.1, "pad": "' + b"x" * 300_000 + b'"}'
    r = harness.post("/render", content=body, headers={"content-type": "application/json"})
    assert r.status_code == 413
    assert "262144" in r.json()["detail"] and "GUITAR_MAX_BODY_BYTES" in r.json()["detail"]


def test_oversized_body_without_content_length(harness) -> None:
    def chunks():  # a generator body is sent chunked, with no Content-Length to trust
        yield b'{"duration": 0.1, "pad": "'
        for _ in range(40):
            yield b"x" * 10_000
        yield b'"}'

    async def send():
        return await harness.client.post("/render", content=_aiter(chunks()),
                                         headers={"content-type": "application/json"})

    r = harness.run(send())
    assert r.status_code == 413
    assert "GUITAR_MAX_BODY_BYTES" in r.json()["detail"]


async def _aiter(it):
    for x in it:
        yield x


# ---- property: whatever the values, the answer is 200 with finite audio or a 4xx ------------

_numbers = st.one_of(
    st.floats(allow_nan=False, allow_infinity=False, min_value=-1e6, max_value=1e6),
    st.integers(-100, 100), st.sampled_from([0, 0.001, 0.5, 1, 2, 24, 1e300]),
    st.text(max_size=3), st.none(), st.booleans(),
)
_event = st.fixed_dictionaries(
    {"type": st.sampled_from(["pluck", "fret", "tap", "bend", 3]),
     "time": st.one_of(st.sampled_from([0.0, 0.01, 0.04]), _numbers),
     "string": st.one_of(st.integers(-1, 13), _numbers)},
    optional={"force": _numbers, "position": _numbers, "fret": st.one_of(st.integers(-1, 30),
                                                                          _numbers),
              "duration": _numbers, "release": _numbers, "velocity": _numbers},
)
_scene = st.fixed_dictionaries(
    {"duration": st.one_of(st.sampled_from([0.02, 0.05]), _numbers)},
    optional={
        "events": st.lists(_event, max_size=4),
        "sample_rate": st.one_of(st.sampled_from([22050, 44100]), _numbers),
        "guitar": st.fixed_dictionaries({}, optional={
            "preset": st.sampled_from(["steel-acoustic", "nylon-classical", "x"]),
            "frets": _numbers, "action_nut_m": _numbers}),
        "output": st.fixed_dictionaries({}, optional={
            "format": st.sampled_from(["wav", "flac", "ogg", "aiff"]),
            "normalize": st.one_of(st.booleans(), _numbers)}),
        "quality": st.sampled_from(["draft", "standard", "best"]),
    },
)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(scene=_scene)
def test_no_input_gives_a_5xx_or_bad_audio(harness, scene: dict[str, Any]) -> None:
    if isinstance(scene.get("duration"), int | float) and scene["duration"] > 0.05:
        scene["duration"] = 0.05  # long valid renders would only slow the search down
    r = harness.post("/render", json=scene)
    assert r.status_code in (200, 422), brief(r)
    if r.status_code == 200:
        x, _, _ = decode(r.content)
        assert np.all(np.isfinite(x)) and np.max(np.abs(x), initial=0.0) <= 1.0
    else:
        assert all(d["message"] for d in r.json()["detail"])
