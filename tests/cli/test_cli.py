"""The ``guitar-synth`` command, run as a subprocess: help, rendering scenes to each format, the
progress bar, and one line with exit status 2 for each kind of bad input."""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

from .helpers import one_error_line, run

SCENE = {"duration": 0.3, "events": [
    {"type": "fret", "time": 0.0, "string": 2, "fret": 1, "force": 2.0},
    {"type": "pluck", "time": 0.01, "string": 2, "force": 2.0},
    {"type": "pluck", "time": 0.05, "string": 6, "force": 2.0}]}


def write_json(path: Path, data: object) -> Path:
    path.write_text(json.dumps(data))
    return path


@pytest.mark.parametrize("args", [[], ["render"], ["scene"], ["serve"]])
def test_every_command_has_help(args: list[str]) -> None:
    r = run(*args, "--help", timeout=60)
    assert r.returncode == 0, r.stderr
    assert r.stdout.startswith(f"usage: guitar-synth {' '.join(args)}".rstrip())
    for word in {"": ["render", "scene", "serve"], "render": ["--labels", "--tracks", "--quality",
                 ".wav", ".flac", ".ogg"], "scene": ["-o"], "serve": ["--host", "--port",
                 "GUITAR_"]}["".join(args[:1])]:
        assert word in r.stdout, word


def test_render_a_scene_to_wav_with_a_progress_bar(tmp_path: Path) -> None:
    out = tmp_path / "out.wav"
    r = run("render", write_json(tmp_path / "s.json", SCENE), "-o", out)
    assert r.returncode == 0, r.stderr
    assert "100%" in r.stderr and "s of audio" in r.stderr  # tqdm's bar, on stderr
    assert r.stdout == ""
    x, rate = sf.read(out)
    info = sf.info(out)
    assert (rate, info.subtype, x.ndim) == (44100, "PCM_16", 1)
    assert len(x) == round(0.3 * 44100)
    # normalized as the API's default: the peak at -1 dBFS (16-bit rounding aside)
    assert 20 * np.log10(np.max(np.abs(x))) == pytest.approx(-1.0, abs=0.01)


def test_render_options_override_the_scene(tmp_path: Path) -> None:
    out = tmp_path / "out.flac"
    r = run("render", write_json(tmp_path / "s.json", SCENE), "-o", out, "--channels", "2",
            "--sample-rate", "48000", "--quality", "draft", "--max-seconds", "0.2", "-q")
    assert r.returncode == 0, r.stderr
    assert r.stderr == ""  # --quiet
    info = sf.info(out)
    assert (info.format, info.samplerate, info.channels, info.frames) == ("FLAC", 48000, 2, 9600)


def test_render_ogg_and_fixed_gain(tmp_path: Path) -> None:
    src = write_json(tmp_path / "s.json", SCENE)
    r = run("render", src, "-o", tmp_path / "a.ogg", "-q")
    assert r.returncode == 0, r.stderr
    assert sf.info(tmp_path / "a.ogg").format == "OGG"
    r = run("render", src, "-o", tmp_path / "fixed.wav", "--no-normalize", "--subtype", "FLOAT",
            "-q")
    assert r.returncode == 0, r.stderr
    x, _ = sf.read(tmp_path / "fixed.wav")
    assert 0.0 < np.max(np.abs(x)) < 0.8  # the fixed gain leaves two plucks of 2 N well below 1


def test_scene_of_a_scene_writes_it_back_with_overrides(tmp_path: Path) -> None:
    r = run("scene", write_json(tmp_path / "s.json", SCENE), "-o", "-", "--quality", "high")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout) == {**SCENE, "quality": "high"}


# ---- bad input: one line naming the problem, exit status 2 ----------------------------------


def test_missing_file(tmp_path: Path) -> None:
    line = one_error_line(run("render", tmp_path / "nope.gp5", "-o", tmp_path / "x.wav"))
    assert "nope.gp5: no such file" in line


def test_empty_file(tmp_path: Path) -> None:
    (tmp_path / "empty.mid").write_bytes(b"")
    assert "empty" in one_error_line(run("scene", tmp_path / "empty.mid", "-o", "-"))


def test_wrong_output_suffix(tmp_path: Path) -> None:
    line = one_error_line(run("render", write_json(tmp_path / "s.json", SCENE),
                              "-o", tmp_path / "x.mp3"))
    assert "'.mp3'" in line and ".wav, .flac or .ogg" in line
    assert not (tmp_path / "x.mp3").exists()


def test_wrong_input_suffix(tmp_path: Path) -> None:
    (tmp_path / "song.txt").write_text("hello")
    line = one_error_line(run("render", tmp_path / "song.txt", "-o", tmp_path / "x.wav"))
    assert "unknown input type '.txt'" in line


def test_output_folder_missing(tmp_path: Path) -> None:
    line = one_error_line(run("render", write_json(tmp_path / "s.json", SCENE),
                              "-o", tmp_path / "no" / "x.wav"))
    assert "does not exist" in line


@pytest.mark.parametrize("scene,expected", [
    ({**SCENE, "duration": -1}, "duration: Input should be greater than 0"),
    ({"duration": 1, "events": [{"type": "pluck", "time": 2.0, "string": 1}]},
     "events[0].time: 2.0 outside 0 <= time < 1"),
    ({"duration": 1, "events": [{"type": "fret", "time": 0, "string": 9, "fret": 2}]},
     "events[0].string"),
    ({"duration": 1, "guitar": {"preset": "banjo"}}, "guitar.preset"),
])
def test_invalid_scene_names_the_field(tmp_path: Path, scene: dict, expected: str) -> None:
    line = one_error_line(run("render", write_json(tmp_path / "s.json", scene),
                              "-o", tmp_path / "x.wav"))
    assert "invalid scene" in line and expected in line, line


def test_malformed_json(tmp_path: Path) -> None:
    (tmp_path / "s.json").write_text('{"duration": 1, "events": [}')
    assert "not valid JSON" in one_error_line(run("render", tmp_path / "s.json",
                                                  "-o", tmp_path / "x.wav"))
    (tmp_path / "n.json").write_text('{"duration": NaN}')
    assert "NaN" in one_error_line(run("render", tmp_path / "n.json", "-o", tmp_path / "x.wav"))
    (tmp_path / "l.json").write_text("[1, 2]")
    assert "JSON object" in one_error_line(run("render", tmp_path / "l.json",
                                               "-o", tmp_path / "x.wav"))


def test_score_options_refused_for_a_scene(tmp_path: Path) -> None:
    line = one_error_line(run("render", write_json(tmp_path / "s.json", SCENE),
                              "-o", tmp_path / "x.wav", "--tracks", "0"))
    assert "--tracks applies to scores" in line


def test_usage_errors_are_one_line(tmp_path: Path) -> None:
    assert "required" in one_error_line(run("render", tmp_path / "s.json"))
    assert "--quality" in one_error_line(run("render", "a.json", "-o", "b.wav",
                                             "--quality", "ultra"))
    assert "--max-seconds" in one_error_line(run("render", "a.json", "-o", "b.wav",
                                                 "--max-seconds", "-3"))


def truncated_gp5() -> bytes:
    """The first bytes of a Guitar Pro 5 file (its version string) and nothing after."""
    version = b"FICHIER GUITAR PRO v5.00"
    return bytes([len(version)]) + version.ljust(30, b"\0") + b"\x05\x00\x00"


def test_truncated_guitar_pro_file(tmp_path: Path) -> None:
    (tmp_path / "t.gp5").write_bytes(truncated_gp5())
    line = one_error_line(run("render", tmp_path / "t.gp5", "-o", tmp_path / "x.wav"))
    assert line.startswith("guitar-synth render: error: ") and "t.gp5" in line


def test_zip_renamed_gp5(tmp_path: Path) -> None:
    with zipfile.ZipFile(tmp_path / "z.gp5", "w") as z:
        z.writestr("Content/score.gpif", "<GPIF/>")  # a Guitar Pro 7 file is a zip like this
    line = one_error_line(run("scene", tmp_path / "z.gp5", "-o", tmp_path / "x.json"))
    assert "z.gp5" in line


def test_truncated_midi_file(tmp_path: Path) -> None:
    (tmp_path / "t.mid").write_bytes(b"MThd\x00\x00\x00\x06\x00\x01\x00\x02\x01\xe0MTrk\x00\x00")
    line = one_error_line(run("scene", tmp_path / "t.mid", "-o", tmp_path / "x.json"))
    assert "t.mid" in line
