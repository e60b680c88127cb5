"""``output.stems`` over HTTP: POST /render and /render/score answer a zip of the mix and each
string's file (the command line's layout), a job keeps them for GET /jobs/{id}/stems with the same
bytes, and /render/stream refuses them naming the field."""

from __future__ import annotations

import io
import json
import time
import zipfile
from collections.abc import Iterator

import numpy as np
import pytest
import soundfile as sf
from conftest import AppHarness
from svc_helpers import brief, fields

import engine
from service.config import Settings
from tests.score_files import small_gp5

SCENE = {"duration": 0.3, "model": "waveguide",
         "output": {"channels": 2, "subtype": "FLOAT", "stems": True}, "tracks": [
             {"name": "Lead", "pan": -0.3, "gain_db": -4.0, "events": [
                 {"type": "fret", "time": 0.0, "string": 3, "fret": 4},
                 {"type": "pluck", "time": 0.01, "string": 3, "force": 2.0},
                 {"type": "slide", "time": 0.1, "string": 3, "from_fret": 4, "to_fret": 6,
                  "duration": 0.05},
                 {"type": "pluck", "time": 0.03, "string": 5}]},
             {"guitar": {"preset": "bass"}, "model": "fdtd",
              "effects": [{"type": "delay", "delay_s": 0.05}],
              "events": [{"type": "pluck", "time": 0.02, "string": 4, "force": 3.0}]}]}
FILES = [f"stems/t1-s{s}.wav" for s in range(6, 0, -1)] + \
    [f"stems/t2-s{s}.wav" for s in range(4, 0, -1)]


@pytest.fixture(scope="module")
def app(tmp_path_factory: pytest.TempPathFactory) -> Iterator[AppHarness]:
    data = tmp_path_factory.mktemp("stems-data")
    h = AppHarness(Settings(workers=2, queue_size=8, data_dir=str(data))).start()
    yield h
    h.stop()


def dry(scene: dict) -> np.ndarray:
    """The dry mix at the fixed gain: every body, pan and effect left out, mono."""
    return engine.render({**scene, "output": {"channels": 1, "body": "none", "normalize": False},
                          "tracks": [{**t, "effects": [], "pan": None} for t in scene["tracks"]]})


def read(z: zipfile.ZipFile, name: str) -> np.ndarray:
    return sf.read(io.BytesIO(z.read(name)), dtype="float64")[0]


@pytest.mark.parametrize("normalize", [True, False])
def test_render_answers_a_zip_of_the_mix_and_its_stems(app, normalize):
    scene = {**SCENE, "output": {**SCENE["output"], "normalize": normalize}}
    r = app.post("/render", json=scene, timeout=120)
    assert r.status_code == 200, brief(r)
    assert r.headers["content-type"] == "application/zip"
    assert 'filename="guitar.zip"' in r.headers["content-disposition"]
    z = zipfile.ZipFile(io.BytesIO(r.content))
    assert sorted(z.namelist()) == sorted(["guitar.wav", *FILES, "stems/stems.json"])
    index = json.loads(z.read("stems/stems.json"))
    assert [f"stems/{s['file']}" for s in index["stems"]] == FILES
    # the mix is /render's file for the scene without stems, or (normalized) the same mix at the
    # gain that keeps every stem whole, as engine.render_result(stems=True) gives it
    plain = app.post("/render", json={**scene, "output": {**scene["output"], "stems": False}})
    mix = read(z, "guitar.wav")
    if normalize:
        joint = engine.render_result(scene, stems=True).audio
        assert np.max(np.abs(mix - joint)) < 1e-6 and np.max(np.abs(mix)) < 0.85
    else:
        assert z.read("guitar.wav") == plain.content
    stems = [read(z, f) for f in FILES]
    assert all(len(s) == len(mix) for s in stems)
    assert index["gain"] == pytest.approx(
        engine.render_result(scene, stems=True).gain if normalize else engine.FIXED_GAIN,
        rel=1e-12)
    expected = dry(scene) / engine.FIXED_GAIN * index["gain"]
    assert np.max(np.abs(sum(stems) - expected)) < 1e-6
    assert np.max(np.abs(expected)) > 0.05 and index["clipped_samples"] == 0


def test_render_score_takes_stems_in_its_output_field(app):
    files = {"file": ("song.gp5", small_gp5(tracks=1), "application/octet-stream")}
    r = app.post("/render/score", files=files, timeout=120,
                 data={"options": json.dumps({"max_seconds": 0.4, "model": "waveguide"}),
                       "output": json.dumps({"format": "flac", "stems": True})})
    assert r.status_code == 200, brief(r)
    assert r.headers["content-type"] == "application/zip"
    z = zipfile.ZipFile(io.BytesIO(r.content))
    names = z.namelist()
    assert "song.flac" in names and "stems/stems.json" in names
    stems = [n for n in names if n.startswith("stems/t")]
    assert stems and all(n.endswith(".flac") for n in stems)
    assert sf.info(io.BytesIO(z.read(stems[0]))).format == "FLAC"


def test_a_stream_refuses_stems_naming_the_field(app):
    r = app.post("/render/stream", json=SCENE)
    assert r.status_code == 422
    assert fields(r) == ["output.stems"]
    assert "POST /render" in r.text


def test_a_job_keeps_the_stems_render_gives(app):
    r = app.post("/jobs", json=SCENE)
    assert r.status_code == 202, r.text
    job_id = r.json()["id"]
    assert r.json()["stems_url"] == f"/jobs/{job_id}/stems"
    deadline = time.monotonic() + 120
    while (job := app.get(f"/jobs/{job_id}").json())["status"] in ("queued", "running"):
        assert time.monotonic() < deadline
        time.sleep(0.1)
    assert job["status"] == "done", job
    s = app.get(f"/jobs/{job_id}/stems")
    assert s.status_code == 200 and s.headers["content-type"] == "application/zip"
    got = zipfile.ZipFile(io.BytesIO(s.content))
    assert sorted(got.namelist()) == sorted([*FILES, "stems/stems.json"])
    ref = zipfile.ZipFile(io.BytesIO(app.post("/render", json=SCENE, timeout=120).content))
    for name in FILES:  # the job's stems have /render's bytes, as its audio has
        assert got.read(name) == ref.read(name), name
    assert json.loads(got.read("stems/stems.json")) == json.loads(ref.read("stems/stems.json"))
    assert app.get(f"/jobs/{job_id}/audio").content == ref.read("guitar.wav")
    # a job that did not ask for stems has none
    plain = app.post("/jobs", json={**SCENE, "output": {"stems": False}}).json()
    assert plain["stems_url"] is None
    assert app.get(f"/jobs/{plain['id']}/stems").status_code == 404
