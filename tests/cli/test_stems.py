"""``guitar-synth render --stems``: one file per string beside the mix, listed in stems.json, in
the mix's format and at its gain, summing to the dry mix (tests/engine/test_stems.py defines it)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

import engine

from .helpers import one_error_line, run

SCENE = {"duration": 0.3, "model": "waveguide", "output": {"channels": 2}, "tracks": [
    {"name": "Lead", "guitar": {"preset": "steel-acoustic"}, "pan": 0.5, "gain_db": -2.0,
     "events": [{"type": "fret", "time": 0.0, "string": 2, "fret": 3},
                {"type": "pluck", "time": 0.01, "string": 2, "force": 2.0},
                {"type": "bend", "time": 0.05, "string": 2, "semitones": 1.0, "duration": 0.05},
                {"type": "pluck", "time": 0.05, "string": 6, "force": 2.0}]},
    {"guitar": {"preset": "bass"}, "effects": [{"type": "drive", "gain_db": 10.0}],
     "model": "fdtd", "events": [{"type": "pluck", "time": 0.02, "string": 3, "force": 3.0}]}]}
DRY = {**SCENE, "output": {"channels": 1, "body": "none", "normalize": False},
       "tracks": [{**t, "effects": [], "pan": None} for t in SCENE["tracks"]]}
TOL = 1e-6  # of full scale (issue 36)


def render(tmp_path: Path, out: str, *flags: str) -> tuple[Path, dict]:
    src = tmp_path / "song.json"
    src.write_text(json.dumps(SCENE))
    r = run("render", src, "-o", tmp_path / out, "--stems", *flags)
    assert r.returncode == 0, r.stderr
    folder = tmp_path / (Path(out).stem + ".stems")
    return folder, json.loads((folder / "stems.json").read_text())


def summed(folder: Path, index: dict) -> np.ndarray:
    return sum(sf.read(folder / s["file"])[0] for s in index["stems"])


@pytest.mark.parametrize("normalize", [False, True])
def test_stems_are_files_that_sum_to_the_dry_mix(tmp_path, normalize):
    folder, index = render(tmp_path, "song.wav", "--subtype", "FLOAT", "-q",
                           *([] if normalize else ["--no-normalize"]))
    files = sorted(p.name for p in folder.iterdir())
    expected = ([f"t1-s{s}.wav" for s in range(6, 0, -1)]
                + [f"t2-s{s}.wav" for s in range(4, 0, -1)])
    assert files == sorted([*expected, "stems.json"])
    assert [s["file"] for s in index["stems"]] == expected  # the labels' order
    assert [s["annotation"] for s in index["stems"]] == list(range(10))
    assert index["stems"][0]["track_name"] == "Lead" and index["stems"][6]["track_name"] == "track 2"
    mix, rate = sf.read(tmp_path / "song.wav")
    for name in expected:
        info = sf.info(folder / name)
        assert (info.samplerate, info.channels, info.subtype, info.frames) == (
            rate, 1, "FLOAT", len(mix))
    # the stems share the mix's gain: the fixed one, or the one that puts the mix at -1 dBFS
    gain = engine.render_result(SCENE, stems=True).gain if normalize else engine.FIXED_GAIN
    assert index["gain"] == pytest.approx(gain, rel=1e-12)
    dry = engine.render(DRY) / engine.FIXED_GAIN * gain
    assert np.max(np.abs(summed(folder, index) - dry)) < TOL
    assert np.max(np.abs(dry)) > 0.05 and index["clipped_samples"] == 0
    # the mix is engine.render's with stems (which may be quieter than without: test_stems)
    expected_mix = engine.render_result({**SCENE, "output": {
        **SCENE["output"], "normalize": normalize}}, stems=True).audio
    assert np.max(np.abs(mix - expected_mix)) < TOL
    assert not any(p.name.endswith(".part") for p in tmp_path.rglob("*"))


def test_stems_take_the_mix_format(tmp_path):
    folder, index = render(tmp_path, "song.flac", "--subtype", "PCM_24", "-q")
    info = sf.info(folder / index["stems"][0]["file"])
    assert (info.format, info.subtype) == ("FLAC", "PCM_24")
    # 24-bit stems of a normalized mix: their sum is the dry mix to the stems' rounding
    dry = engine.render(DRY) / engine.FIXED_GAIN * index["gain"]
    assert np.max(np.abs(summed(folder, index) - dry)) < 10 * 2.0 ** -23


def test_a_stems_path_that_is_a_file_is_one_line(tmp_path):
    (tmp_path / "song.stems").write_text("not a folder")
    src = tmp_path / "song.json"
    src.write_text(json.dumps(SCENE))
    r = run("render", src, "-o", tmp_path / "song.wav", "--stems")
    assert "--stems" in one_error_line(r) and "not a folder" in r.stderr


def test_batch_writes_stems_per_item_and_lists_them_in_the_manifest(tmp_path):
    import os
    import subprocess
    import sys

    import pyarrow.parquet as pq

    from .helpers import ROOT

    inputs = tmp_path / "in"
    inputs.mkdir()
    (inputs / "song.json").write_text(json.dumps(
        {**SCENE, "output": {**SCENE["output"], "subtype": "FLOAT"}}))
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(
        p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p)}

    def batch() -> dict:
        r = subprocess.run([sys.executable, "-m", "cli.main", "batch", str(inputs), "-o",
                            str(out), "--workers", "1", "--stems", "-q"], capture_output=True,
                           text=True, timeout=600, env=env, cwd=ROOT)
        assert r.returncode == 0, r.stderr[-3000:]
        (row,) = pq.read_table(out / "manifest.parquet").to_pylist()
        return row

    row = batch()
    assert row["status"] == "done" and row["stems"] == "stems/song"
    index = json.loads((out / "stems/song/stems.json").read_text())
    assert len(index["stems"]) == 10
    assert index["gain"] == pytest.approx(engine.render_result(SCENE, stems=True).gain,
                                          rel=1e-12)
    dry = engine.render(DRY) / engine.FIXED_GAIN * index["gain"]
    assert np.max(np.abs(summed(out / "stems/song", index) - dry)) < TOL
    mix = sf.read(out / row["audio"])[0]
    assert sf.info(out / "stems/song/t1-s2.wav").frames == len(mix)
    stamp = (out / "stems/song/t1-s2.wav").stat().st_mtime_ns
    assert batch()["stems"] == "stems/song"  # run again: done, nothing rewritten
    assert (out / "stems/song/t1-s2.wav").stat().st_mtime_ns == stamp
