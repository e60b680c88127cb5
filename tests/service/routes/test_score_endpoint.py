"""POST /score/scene, POST /render/score and POST /scene/labels over real HTTP (uvicorn): a Guitar
Pro upload becomes a scene, audio and labels; every kind of bad upload is a 4xx naming the field,
and none of them costs a worker."""

from __future__ import annotations

import io
import json
import time
from typing import Any

import httpx
import numpy as np
import pytest
from svc_helpers import brief, decode

import engine
from tests.score_files import (
    NOTES,
    STANDARD_TUNING,
    gp5_claiming_measures,
    midi_with_notes,
    small_gp5,
    truncated_gp5,
    truncated_midi,
    zip_as_gp5,
)


def post(server: Any, path: str, data: bytes | None = None, name: str = "song.gp5",
         timeout: float = 120.0, **form: Any) -> httpx.Response:
    files = {"file": (name, data, "application/octet-stream")} if data is not None else None
    fields = {k: v if isinstance(v, str) else json.dumps(v) for k, v in form.items()}
    return httpx.post(server.url + path, files=files, data=fields, timeout=timeout)


def fields(r: httpx.Response) -> list[str]:
    return [d["field"] for d in r.json()["detail"]]


def test_score_scene(server) -> None:
    r = post(server, "/score/scene", small_gp5())
    assert r.status_code == 200, brief(r)
    scene = r.json()
    sc = engine.parse_scene(scene)  # what /render accepts
    assert [t.name for t in sc.tracks] == ["", "Track 2"] or len(sc.tracks) == 2
    plucks = [e for e in scene["tracks"][1]["events"] if e["type"] == "pluck"]
    assert [(e["string"], e["time"]) for e in plucks] == \
        [(s, pytest.approx(0.5 * i)) for i, (s, _) in enumerate(NOTES)]
    assert "X-Score-Warnings" not in r.headers  # nothing in this file is unplayable


def test_score_scene_options(server) -> None:
    r = post(server, "/score/scene", small_gp5(), options={
        "tracks": [2], "presets": "nylon-classical", "tempo_scale": 2.0, "quality": "draft"})
    assert r.status_code == 200, brief(r)
    scene = r.json()
    assert [t["name"] for t in scene["tracks"]] == ["Track 2"]
    assert scene["tracks"][0]["guitar"]["preset"] == "nylon-classical"
    assert scene["quality"] == "draft"
    plucks = [e["time"] for e in scene["tracks"][0]["events"] if e["type"] == "pluck"]
    assert plucks == pytest.approx([0.0, 0.25, 0.5, 0.75])  # twice as fast


def test_render_score(server) -> None:
    r = post(server, "/render/score", small_gp5(tracks=1),
             options={"max_seconds": 2.2, "quality": "draft"}, output={"format": "flac",
                                                                       "channels": 2})
    assert r.status_code == 200, brief(r)
    assert r.headers["content-type"] == "audio/flac"
    assert 'filename="song.flac"' in r.headers["content-disposition"]
    assert float(r.headers["x-render-seconds"]) > 0
    x, rate, info = decode(r.content)
    assert (info.channels, len(x)) == (2, round(2.2 * rate))
    assert np.all(np.isfinite(x)) and np.max(np.abs(x)) > 0.5
    # a format name alone is enough for `output`
    r = post(server, "/render/score", small_gp5(tracks=1), options={"max_seconds": 0.3},
             output="ogg")
    assert r.status_code == 200, brief(r)
    assert r.headers["content-type"] == "audio/ogg"


def test_score_on_the_waveguide_model(server) -> None:
    """options.model is the scene's model: /render/score renders what /render does with the
    scene /score/scene gives for the same options."""
    opts = {"max_seconds": 1.0, "model": "waveguide"}
    r = post(server, "/score/scene", small_gp5(tracks=1), options=opts)
    assert r.status_code == 200, brief(r)
    scene = r.json()
    assert scene["model"] == "waveguide"
    direct = httpx.post(server.url + "/render", json=scene, timeout=120)
    assert direct.status_code == 200, brief(direct)
    r = post(server, "/render/score", small_gp5(tracks=1), options=opts)
    assert r.status_code == 200, brief(r)
    assert r.content == direct.content
    fdtd = post(server, "/render/score", small_gp5(tracks=1), options={"max_seconds": 1.0})
    assert fdtd.status_code == 200, brief(fdtd)
    assert fdtd.content != r.content


def test_scene_labels(server) -> None:
    import jams

    scene = post(server, "/score/scene", small_gp5(tracks=1)).json()
    r = httpx.post(server.url + "/scene/labels", json=scene, timeout=60)
    assert r.status_code == 200, brief(r)
    jam = jams.load(io.StringIO(r.text))
    notes = sorted((o.time, o.value) for a in jam.search(namespace="note_midi") for o in a.data)
    open_midi = dict(enumerate(STANDARD_TUNING, 1))
    assert notes == [(pytest.approx(0.5 * i), open_midi[s] + f) for i, (s, f) in enumerate(NOTES)]
    # the score's bars and beats (one bar of 4/4 at 120 bpm) come with the scene, and as beat
    # and tempo labels
    info = scene["score"]
    assert info["beats"] == pytest.approx([0, 0.5, 1, 1.5]) and info["beat_positions"] == [1, 2, 3, 4]
    assert info["bars"] == [0.0] and info["bar_numbers"] == [1]
    r = post(server, "/score/labels", small_gp5(tracks=1), options={"tempo_scale": 2.0})
    assert r.status_code == 200, brief(r)
    jam = jams.load(io.StringIO(r.text))
    (beat,) = jam.search(namespace="beat")
    assert [(o.time, o.value) for o in beat.data] == [
        (pytest.approx(0.25 * i), i + 1) for i in range(4)]
    assert [o.value for o in jam.search(namespace="tempo")[0].data] == [240]


# ---- bad uploads --------------------------------------------------------------------------------


@pytest.mark.parametrize("path", ["/score/scene", "/render/score"])
@pytest.mark.parametrize("data,name,field,text", [
    (None, "", "file", "Field required"),
    (b"", "song.gp5", "file", "empty"),
    (b"hello", "song.txt", "file", "unknown type '.txt'"),
    (truncated_gp5(), "t.gp5", "file", "t.gp5: Guitar Pro file is truncated"),
    (zip_as_gp5(), "z.gp5", "file", "z.gp5: a zip archive"),
    (truncated_midi(), "t.mid", "file", "t.mid"),
    (b"\x00" * 100, "song.mid", "file", "not a MIDI file"),
    (gp5_claiming_measures(10**9), "billion.gp5", "file", "declares 1000000000 measures"),
])
def test_bad_uploads_are_422_naming_the_problem(server, path: str, data: bytes | None, name: str,
                                                field: str, text: str) -> None:
    before = httpx.get(server.url + "/health").json()["pool"]["replaced"]
    r = post(server, path, data, name)
    assert r.status_code == 422, brief(r)
    body = r.json()["detail"]
    assert fields(r) == [field] and text in body[0]["message"], body
    assert httpx.get(server.url + "/health").json()["pool"]["replaced"] == before


@pytest.mark.parametrize("options,field", [
    ("{not json", "options"),
    ([1, 2], "options"),
    ({"tempo": 2}, "options.tempo"),
    ({"tempo_scale": 0}, "options.tempo_scale"),
    ({"tracks": []}, "options.tracks"),
    ({"max_seconds": -1}, "options.max_seconds"),
    ({"tempo_scale": "NaN"}, "options.tempo_scale"),
    ({"presets": "banjo"}, "options.presets"),  # refused by the importer, in the worker
    ({"sample_rate": 1000}, "options.sample_rate"),
    ({"quality": "ultra"}, "options.quality"),
    ({"model": "spline"}, "options.model"),
])
def test_bad_options_name_the_field(server, options: Any, field: str) -> None:
    r = post(server, "/score/scene", small_gp5(), options=options)
    assert r.status_code == 422, brief(r)
    assert field in fields(r), r.json()


def test_bad_output_names_the_field(server) -> None:
    r = post(server, "/render/score", small_gp5(), output={"format": "mp3"})
    assert r.status_code == 422, brief(r)
    assert fields(r) == ["output.format"]


def test_a_score_longer_than_the_limit_is_refused_unless_cut(server) -> None:
    limit = httpx.get(server.url + "/limits").json()["max_duration_s"]
    long = small_gp5(notes=((1, 0),) * 4, tracks=1, tempo=30, duration=1)  # 4 whole notes, 32 s
    assert limit < 32
    r = post(server, "/render/score", long)
    assert r.status_code == 422, brief(r)
    assert fields(r) == ["options.max_seconds"] and f"{limit:g} s" in r.json()["detail"][0]["msg"]
    r = post(server, "/render/score", long, options={"max_seconds": limit + 1})
    assert r.status_code == 422 and fields(r) == ["options.max_seconds"], brief(r)
    r = post(server, "/render/score", long, options={"max_seconds": 0.5, "quality": "draft"})
    assert r.status_code == 200, brief(r)


def test_an_upload_over_the_body_limit_is_413(server) -> None:
    limit = httpx.get(server.url + "/limits").json()["max_body_bytes"]
    r = post(server, "/score/scene", small_gp5() + b"\x00" * limit)
    assert r.status_code == 413, brief(r)
    r = post(server, "/render/score", midi_with_notes(10**6), "million.mid")  # 6 MB
    assert r.status_code == 413, brief(r)


def test_render_a_scene_of_tracks(server) -> None:
    """/render takes the scene /score/scene gives (tracks and all) and renders it."""
    scene = post(server, "/score/scene", small_gp5(), options={"max_seconds": 0.6}).json()
    r = httpx.post(server.url + "/render", json=scene, timeout=120)
    assert r.status_code == 200, brief(r)
    x, rate, _ = decode(r.content)
    assert len(x) == round(0.6 * rate) and np.max(np.abs(x)) > 0.5


def test_an_import_past_its_time_limit_is_stopped_in_its_worker(tmp_path) -> None:
    """The import runs in a worker under its own deadline: past it the worker is killed (504) and
    replaced, and the service goes on answering."""
    from conftest import UvicornServer

    s = UvicornServer(tmp_path, {"GUITAR_WORKERS": "1",
                                 "GUITAR_SCORE_IMPORT_TIME_LIMIT_S": "0.001"}).start()
    try:
        r = post(s, "/score/scene", small_gp5())
        assert r.status_code == 504, brief(r)
        assert "importing the score took longer" in r.json()["detail"]
        # the 504 is answered at the deadline; the worker's exit, which counts the replacement,
        # is seen when the killed process has gone, which may be a moment later
        deadline = time.monotonic() + 10.0
        while (replaced := httpx.get(s.url + "/health", timeout=5).json()["pool"]["replaced"]) == 0:
            if time.monotonic() > deadline:
                break
            time.sleep(0.05)
        assert replaced == 1
    finally:
        s.stop()
