"""The ``guitar-synth`` command, run as a subprocess: help, rendering scenes to each format, the
progress bar, and one line with exit status 2 for each kind of bad input."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf

from ..score_files import (
    NOTES,
    STANDARD_TUNING,
    gp5_claiming_measures,
    midi_with_notes,
    small_gp5,
    small_midi,
    truncated_gp5,
    truncated_midi,
    zip_as_gp5,
)
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
                 "--model", "--jobs", ".wav", ".flac", ".ogg"], "scene": ["-o"],
                 "serve": ["--host", "--port", "GUITAR_"]}["".join(args[:1])]:
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


def test_model_overrides_every_track(tmp_path: Path) -> None:
    """--model sets the scene's model and drops a track's own, so every track plays it."""
    scene = {"duration": 0.3, "model": "fdtd", "tracks": [
        {"model": "fdtd", "events": SCENE["events"]}, {"events": SCENE["events"][2:]}]}
    r = run("scene", write_json(tmp_path / "s.json", scene), "-o", "-", "--model", "waveguide")
    assert r.returncode == 0, r.stderr
    assert json.loads(r.stdout) == {"duration": 0.3, "model": "waveguide", "tracks": [
        {"events": SCENE["events"]}, {"events": SCENE["events"][2:]}]}


def test_render_with_the_waveguide_model(tmp_path: Path) -> None:
    """--model waveguide renders what the scene's own "model": "waveguide" renders, and not
    what the finite-difference model does."""
    def render(scene: dict, *flags: str) -> np.ndarray:
        out = tmp_path / f"{len(list(tmp_path.iterdir()))}.wav"
        r = run("render", write_json(tmp_path / "in.json", scene), "-o", out, "--no-normalize",
                "--subtype", "FLOAT", "-q", *flags)
        assert r.returncode == 0, r.stderr
        return sf.read(out)[0]

    flag = render(SCENE, "--model", "waveguide")
    assert np.all(np.isfinite(flag)) and np.max(np.abs(flag)) > 1e-3
    assert np.array_equal(flag, render({**SCENE, "model": "waveguide"}))
    fdtd = render({**SCENE, "model": "waveguide"}, "--model", "fdtd")
    assert np.array_equal(fdtd, render(SCENE))
    assert not np.allclose(flag, fdtd, atol=1e-3)


def test_jobs_give_the_samples_of_one_thread(tmp_path: Path) -> None:
    """--jobs 2 spreads the strings of both tracks over two threads: the same file as --jobs 1
    (and the default, every core)."""
    scene = {"duration": 0.3, "output": {"channels": 2}, "tracks": [
        {"events": SCENE["events"]}, {"model": "waveguide", "events": SCENE["events"][1:]}]}
    src = write_json(tmp_path / "s.json", scene)
    files = []
    for flags in (["--jobs", "1"], ["--jobs", "2"], []):
        files.append(tmp_path / f"{len(files)}.wav")
        r = run("render", src, "-o", files[-1], "--subtype", "FLOAT", "-q", *flags)
        assert r.returncode == 0, r.stderr
    one, *others = (sf.read(f)[0] for f in files)
    assert np.max(np.abs(one)) > 0.1
    assert all(o.tobytes() == one.tobytes() for o in others)


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
    assert "--model" in one_error_line(run("render", "a.json", "-o", "b.wav",
                                           "--model", "spline"))
    for jobs in ("0", "-2", "two"):
        assert "--jobs" in one_error_line(run("render", "a.json", "-o", "b.wav", "--jobs", jobs))


def test_an_unknown_preset_for_a_score_names_the_flag(tmp_path: Path) -> None:
    (tmp_path / "s.gp5").write_bytes(small_gp5())
    line = one_error_line(run("scene", tmp_path / "s.gp5", "-o", "-", "--preset", "banjo"))
    assert "--preset: unknown preset 'banjo'" in line


def test_truncated_guitar_pro_file(tmp_path: Path) -> None:
    (tmp_path / "t.gp5").write_bytes(truncated_gp5())
    line = one_error_line(run("render", tmp_path / "t.gp5", "-o", tmp_path / "x.wav"))
    assert line.startswith("guitar-synth render: error: ") and "t.gp5" in line


def test_zip_renamed_gp5(tmp_path: Path) -> None:
    (tmp_path / "z.gp5").write_bytes(zip_as_gp5())
    line = one_error_line(run("scene", tmp_path / "z.gp5", "-o", tmp_path / "x.json"))
    assert "z.gp5" in line and "zip" in line


@pytest.mark.parametrize("name,data,text", [
    ("billion.gp5", gp5_claiming_measures(10**9), "declares 1000000000 measures"),
    ("million.mid", midi_with_notes(10**6), "more than 100000 notes"),
])
def test_hostile_files(tmp_path: Path, name: str, data: bytes, text: str) -> None:
    (tmp_path / name).write_bytes(data)
    line = one_error_line(run("render", tmp_path / name, "-o", tmp_path / "x.wav", timeout=60))
    assert name in line and text in line, line


def test_truncated_midi_file(tmp_path: Path) -> None:
    (tmp_path / "t.mid").write_bytes(truncated_midi())
    line = one_error_line(run("scene", tmp_path / "t.mid", "-o", tmp_path / "x.json"))
    assert "t.mid" in line


# ---- scores -----------------------------------------------------------------------------------


def test_scene_of_a_guitar_pro_file(tmp_path: Path) -> None:
    (tmp_path / "s.gp5").write_bytes(small_gp5())
    r = run("scene", tmp_path / "s.gp5", "-o", tmp_path / "s.json", "--tracks", "2",
            "--preset", "nylon-classical")
    assert r.returncode == 0, r.stderr
    scene = json.loads((tmp_path / "s.json").read_text())
    assert [t["name"] for t in scene["tracks"]] == ["Track 2"]
    assert scene["tracks"][0]["guitar"]["preset"] == "nylon-classical"
    plucks = [(e["string"], e["time"]) for e in scene["tracks"][0]["events"]
              if e["type"] == "pluck"]
    assert [s for s, _ in plucks] == [s for s, _ in NOTES]  # the score's strings, in its order
    assert [t for _, t in plucks] == pytest.approx([0.0, 0.5, 1.0, 1.5])  # quarters at 120 bpm


def test_render_a_guitar_pro_file_with_labels(tmp_path: Path) -> None:
    import jams

    (tmp_path / "s.gp5").write_bytes(small_gp5(tracks=1))
    r = run("render", tmp_path / "s.gp5", "-o", tmp_path / "s.wav", "--labels",
            tmp_path / "s.jams", "--max-seconds", "2.2", "--quality", "draft")
    assert r.returncode == 0, r.stderr
    x, rate = sf.read(tmp_path / "s.wav")
    assert len(x) == round(2.2 * rate) and np.all(np.isfinite(x)) and np.max(np.abs(x)) > 0.5
    jam = jams.load(str(tmp_path / "s.jams"))
    notes = sorted((o.time, o.value) for a in jam.search(namespace="note_midi") for o in a.data)
    open_midi = dict(enumerate(STANDARD_TUNING, 1))
    assert notes == [(pytest.approx(0.5 * i), open_midi[s] + f) for i, (s, f) in enumerate(NOTES)]
    made = jam.sandbox.guitar_synth  # what made the audio, in the file
    assert (made["source"], made["format"], made["input"]) == ("s.gp5", "gp", "s.gp5")
    assert (made["model"], made["quality"], made["tracks"][0]["tuning"][0]) == ("fdtd", "draft",
                                                                                 "E4")
    assert jam.file_metadata.title == "s" and jam.search(namespace="pitch_contour")


def test_scene_of_a_midi_file_gets_strings_and_frets(tmp_path: Path) -> None:
    (tmp_path / "tune.mid").write_bytes(small_midi((52, 55, 59, 64)))  # E3 G3 B3 E4
    r = run("scene", tmp_path / "tune.mid", "-o", "-")
    assert r.returncode == 0, r.stderr
    scene = json.loads(r.stdout)
    (track,) = scene["tracks"]
    assert track["guitar"]["preset"] == "steel-acoustic"  # GM program 25
    plucks = [e for e in track["events"] if e["type"] == "pluck"]
    assert [e["time"] for e in plucks] == pytest.approx([0.0, 0.5, 1.0, 1.5])
    held = {}  # the fret each string holds when it is plucked: open pitch + fret = the note
    for e in sorted(track["events"], key=lambda e: (e["time"], e["type"] != "fret")):
        if e["type"] == "fret":
            held[e["string"]] = e["fret"]
        elif e["type"] == "pluck":
            e["pitch"] = STANDARD_TUNING[e["string"] - 1] + held.get(e["string"], 0)
    assert [e["pitch"] for e in plucks] == [52, 55, 59, 64]


def test_serve_answers_health_and_stops(tmp_path: Path) -> None:
    """`guitar-synth serve` is the service (GET /health, /limits with GUITAR_* settings), with
    one access log line per request: the service's JSON line, not uvicorn's plain one too."""
    import os
    import signal
    import socket
    import subprocess
    import time

    import httpx

    from .helpers import ROOT, command

    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        port = s.getsockname()[1]
    env = {**os.environ, "PYTHONPATH": str(ROOT), "GUITAR_MAX_EVENTS": "123"}
    log = open(tmp_path / "serve.log", "wb")  # noqa: SIM115 - closed below
    proc = subprocess.Popen([command(), "serve", "--port", str(port), "--workers", "1",
                             "--log-level", "info"], env=env, stdout=log,
                            stderr=subprocess.STDOUT)
    try:
        deadline = time.monotonic() + 120
        while True:
            assert proc.poll() is None, (tmp_path / "serve.log").read_text()[-2000:]
            try:
                if httpx.get(f"http://127.0.0.1:{port}/health", timeout=2).status_code == 200:
                    break
            except httpx.TransportError:
                pass
            assert time.monotonic() < deadline, "not healthy within 120 s"
            time.sleep(0.2)
        limits = httpx.get(f"http://127.0.0.1:{port}/limits", timeout=5).json()
        assert limits["max_events"] == 123
    finally:
        os.kill(proc.pid, signal.SIGTERM)
        # uvicorn shuts down (the pool's workers with it), then re-raises the signal it caught,
        # as `uvicorn service.app:app` does
        assert proc.wait(30) in (0, -signal.SIGTERM)
        log.close()
    text = (tmp_path / "serve.log").read_text()
    assert '"path": "/limits"' in text, text[-2000:]
    assert "GET /limits HTTP" not in text, text[-2000:]


def test_the_command_knows_the_engine_by_its_public_names() -> None:
    """cli/ imports ``engine`` itself, never a module inside it, and the service only by the
    application's name (``service.app:app``, as uvicorn runs it)."""
    import ast

    from .helpers import ROOT

    for path in (ROOT / "cli").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            for name in names:
                assert not name.startswith(("engine.", "service")), (path.name, name)


def test_a_render_says_when_it_calibrates_frets_and_only_then(tmp_path: Path) -> None:
    scene = write_json(tmp_path / "s.json", {**SCENE, "quality": "standard"})
    env = {"GUITAR_CACHE_DIR": str(tmp_path / "calibrations")}  # an empty store: after install
    first = run("render", scene, "-o", tmp_path / "a.wav", env=env)
    assert first.returncode == 0, first.stderr
    assert "calibrating frets" in first.stderr
    second = run("render", scene, "-o", tmp_path / "b.wav", env=env)
    assert second.returncode == 0, second.stderr
    assert "calibrating" not in second.stderr and "compiling" not in second.stderr
    assert "tuning" not in second.stderr
    assert sf.read(tmp_path / "a.wav")[0].tobytes() == sf.read(tmp_path / "b.wav")[0].tobytes()


def test_a_render_says_when_it_compiles_kernels(monkeypatch, capsys) -> None:
    from cli import main as cli_main
    from engine import precompile
    from engine.scene import Scene

    models = []
    monkeypatch.setattr(precompile, "kernels_cached", lambda m: False)
    monkeypatch.setattr(precompile, "prepare_kernels", lambda m: models.append(set(m)) or 1.0)
    sc = Scene.model_validate({**SCENE, "model": "waveguide"})
    cli_main.prepare_kernels(sc, quiet=False)
    err = capsys.readouterr().err
    assert "compiling kernels (waveguide), first run only" in err and "compiled in" in err
    assert models == [{"waveguide"}]
    cli_main.prepare_kernels(sc, quiet=True)
    assert capsys.readouterr().err == ""


def test_a_render_freezes_what_the_process_holds_before_it_renders(monkeypatch) -> None:
    """Once the kernels are loaded, the CLI moves the process's objects (numba's, the modules')
    out of the garbage collector's sight: the full collections during the render and at the exit
    do not walk them (``python -m tools.startup`` measures the exit's part)."""
    import gc

    from cli import main as cli_main
    from engine.scene import Scene

    frozen = []
    real_prepare = cli_main.prepare_kernels
    monkeypatch.setattr(cli_main, "prepare_kernels",
                        lambda sc, quiet: (real_prepare(sc, quiet), frozen.append(
                            gc.get_freeze_count())))
    gc.unfreeze()
    try:
        audio, _ = cli_main.render_audio(
            Scene.model_validate({**SCENE, "model": "waveguide", "duration": 0.1}), quiet=True)
        assert frozen == [0]  # nothing frozen before the kernels are loaded
        assert gc.get_freeze_count() > 100_000  # numba's objects and the engine's
        assert np.all(np.isfinite(audio)) and np.any(audio)
    finally:
        gc.unfreeze()
