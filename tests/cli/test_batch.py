"""guitar-synth batch (cli/batch.py): specs, manifests, resuming, and Dask clusters of real
processes on 127.0.0.1 (a scheduler and two workers, one of them killed mid-batch).

Every scene is tiny (draft quality, a second or two) and every process started here is stopped
by its PID."""

from __future__ import annotations

import json
import os
import signal
import socket
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
import soundfile as sf

import engine
from cli import batch
from engine.testing.scores import gp5_song

ROOT = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": os.pathsep.join(
    p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p)}


def spec(path: Path, count: int = 3, **fields) -> Path:
    d = {"name": "t", "seed": 5, "count": count, "duration": [0.3, 0.6],
         "presets": ["steel-acoustic", "nylon-classical"], "qualities": ["draft"], **fields}
    path.write_text(json.dumps({"dataset": d}))
    return path


def cli(*args, timeout: float = 600.0) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "cli.main", "batch", *map(str, args)],
                          capture_output=True, text=True, timeout=timeout, env=ENV, cwd=ROOT)


def manifest(out: Path) -> dict[str, dict]:
    rows = pq.read_table(out / "manifest.parquet").to_pylist()
    ids = [r["id"] for r in rows]
    assert len(ids) == len(set(ids)), "an item has more than one row"
    return {r["id"]: r for r in rows}


# ---- bad input: one line, exit 2, nothing rendered ------------------------------------------------


@pytest.mark.parametrize("fields,words", [
    ({"colour": "red"}, ["dataset.colour", "unknown key"]),
    ({"duration": [5, 2]}, ["dataset.duration", "low 5 is above high 2"]),
    ({"pluck_force_n": [0.5, 1e6]}, ["dataset.pluck_force_n", "within"]),
    ({"presets": ["banjo"]}, ["dataset.presets", "banjo"]),
    ({"count": 0}, ["dataset.count"]),
    ({"tunings": [["E2", "H3"]]}, ["dataset.tunings", "H3"]),
])
def test_bad_spec_is_one_line_and_exit_2(tmp_path: Path, capsys, fields, words) -> None:
    code = batch.main([str(spec(tmp_path / "s.json", **fields)), "-o", str(tmp_path / "out")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1, err
    assert all(w in err[0] for w in words), err[0]
    assert not (tmp_path / "out").exists()


def test_yaml_spec_errors_name_the_field(tmp_path: Path, capsys) -> None:
    p = tmp_path / "s.yaml"
    p.write_text("dataset:\n  count: 2\n  tempo_bpm: [200, 100]\n")
    assert batch.main([str(p), "-o", str(tmp_path / "out")]) == 2
    assert "dataset.tempo_bpm" in capsys.readouterr().err


def test_unwritable_output_folder_is_a_clear_error(tmp_path: Path, capsys) -> None:
    blocker = tmp_path / "file"
    blocker.write_text("not a folder")
    code = batch.main([str(spec(tmp_path / "s.json")), "-o", str(blocker / "out")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "cannot write the output folder" in err[0], err


def test_a_spec_draws_the_same_scenes_in_any_order(tmp_path: Path) -> None:
    from cli import dataset

    s = dataset.load_spec(spec(tmp_path / "s.json", count=20))
    forward = [dataset.draw_scene(s, i) for i in range(20)]
    backward = [dataset.draw_scene(s, i) for i in reversed(range(20))][::-1]
    assert forward == backward
    assert len({json.dumps(x, sort_keys=True) for x in forward}) == 20


def test_a_spec_draws_models_only_when_it_names_them(tmp_path: Path) -> None:
    """``models`` is drawn last and only from a choice: a spec that names just fdtd draws the
    scenes a spec without the key draws; one with both draws each model."""
    from cli import dataset

    plain = dataset.load_spec(spec(tmp_path / "a.json", count=20))
    fd = dataset.load_spec(spec(tmp_path / "b.json", count=20, models=["fdtd"]))
    both = dataset.load_spec(spec(tmp_path / "c.json", count=20, models=["fdtd", "waveguide"]))
    drawn = [dataset.draw_scene(both, i) for i in range(20)]
    assert [dataset.draw_scene(plain, i) for i in range(20)] == [
        dataset.draw_scene(fd, i) for i in range(20)]
    assert {x.get("model", "fdtd") for x in drawn} == {"fdtd", "waveguide"}
    for x in drawn:  # the rest of each scene as the plain spec draws it
        x.pop("model", None)
    assert drawn == [dataset.draw_scene(plain, i) for i in range(20)]


def test_batch_model_overrides_every_track(tmp_path: Path) -> None:
    """``--model waveguide`` renders a scene whose track asks for fdtd on the waveguide: the
    audio is the scene's own render with the model set on the scene and taken off the track."""
    out = tmp_path / "out"
    for sub in ("audio", "labels"):
        (out / sub).mkdir(parents=True)
    track = {"model": "fdtd", "events": [{"type": "pluck", "time": 0.0, "string": 2}]}
    scene = {"duration": 0.2, "quality": "draft", "tracks": [track]}
    item = batch.Item(id="x", input="x.json", kind="drawn", scene=scene)
    row = batch.render_item(item, str(out), {"format": "wav", "labels": False,
                                             "model": "waveguide"})
    assert row["status"] == "done", row
    got, _ = sf.read(out / row["audio"])
    on_wg = {**scene, "model": "waveguide", "tracks": [{"events": track["events"]}]}
    want = np.asarray(engine.render(on_wg))
    assert got.shape == want.shape and np.max(np.abs(got - want)) <= 1.0 / 32768  # 16-bit
    fd = np.asarray(engine.render(scene))
    assert np.max(np.abs(fd - want)) > 1e-3  # the models differ: the override took effect


# ---- a local cluster: outputs, failures, determinism, resuming -----------------------------------


def test_local_batch_fails_bad_items_renders_the_rest_and_resumes(tmp_path: Path) -> None:
    inputs = tmp_path / "in"
    inputs.mkdir()
    (inputs / "scene.json").write_text(json.dumps({
        "duration": 0.4, "quality": "draft",
        "events": [{"type": "pluck", "time": 0.0, "string": 2, "force": 1.5}]}))
    (inputs / "broken.json").write_text('{"duration": 0.4, "events": [')  # cut off
    (inputs / "tune.gp5").write_bytes(gp5_song([(3, 0), (2, 1)], tempo=240))  # 0.5 s
    (inputs / "broken.gp5").write_bytes(b"FICHIER GUITAR PRO v5.00 but nothing else")
    out = tmp_path / "out"
    r = cli(inputs, spec(tmp_path / "s.json"), "-o", out, "--workers", "1")
    assert r.returncode == 1, r.stderr[-3000:]  # some items failed
    rows = manifest(out)
    assert set(rows) == {"scene", "tune", "broken", "broken-2", "t-000000", "t-000001",
                         "t-000002"}
    failed = {k: v for k, v in rows.items() if v["status"] != "done"}
    assert set(failed) == {"broken", "broken-2"}
    assert all(v["error"] for v in failed.values())
    reasons = sorted(v["error"].lower() for v in failed.values())
    assert any("json" in e or "expecting" in e for e in reasons), reasons  # the cut-off scene
    for k, v in rows.items():
        if k in failed:
            assert v["audio"] is None
            continue
        x, rate = sf.read(out / v["audio"])
        assert len(x) == round(v["audio_seconds"] * rate) and v["render_seconds"] > 0
        assert (out / v["labels"]).stat().st_size > 0
        assert v["files"] == [v["audio"], v["labels"]]
        assert v["model"] == "fdtd" and v["duration"] == pytest.approx(v["audio_seconds"], abs=1e-4)
    assert not list(out.rglob("*.part"))
    # the columns to filter a dataset by, and the same in each labels file
    tune, scene, drawn = rows["tune"], rows["scene"], rows["t-000000"]
    assert [r["content"] for r in (tune, scene, drawn)] == ["score", "scene", "dataset"]
    assert (tune["preset"], tune["quality"], tune["notes"]) == ("steel-acoustic", "standard", 2)
    assert tune["tuning"] == "E2 A2 D3 G3 B3 E4" and tune["articulations"] == ["pluck"]
    assert drawn["preset"] in ("steel-acoustic", "nylon-classical") and drawn["quality"] == "draft"
    meta = json.loads((out / drawn["labels"]).read_text())["sandbox"]["guitar_synth"]
    assert (meta["seed"], meta["tracks"][0]["preset"]) == (drawn["seed"], drawn["preset"])
    assert meta["version"] and meta["quality"] == "draft" and meta["input"] == drawn["input"]

    # the same spec elsewhere: the same audio, bit for bit
    out2 = tmp_path / "out2"
    r2 = cli(spec(tmp_path / "s.json"), "-o", out2, "--workers", "1")
    assert r2.returncode == 0, r2.stderr[-3000:]
    for k, v in manifest(out2).items():
        assert (out2 / v["audio"]).read_bytes() == (out / rows[k]["audio"]).read_bytes(), k

    # run again: what is done is skipped, what failed (or lost its file) is redone
    (out / rows["t-000001"]["audio"]).unlink()
    before = {k: v["render_seconds"] for k, v in rows.items()}
    r3 = cli(inputs, spec(tmp_path / "s.json"), "-o", out, "--workers", "1")
    assert r3.returncode == 1
    assert "4 skipped as done before" in r3.stderr, r3.stderr[-2000:]
    again = manifest(out)
    assert again["t-000001"]["status"] == "done"
    assert again["t-000001"]["render_seconds"] != before["t-000001"]
    assert again["t-000000"]["render_seconds"] == before["t-000000"]


def test_list_columns_survive_a_csv_manifest(tmp_path: Path) -> None:
    row = {"id": "a", "status": "done", "articulations": ["hammer_on", "pluck"],
           "files": ["audio/a.wav", "labels/a.jams"], "notes": 3}
    for fmt in ("csv", "parquet"):
        batch.write_manifest(tmp_path, fmt, [row])
        back = batch.read_manifest(tmp_path, fmt)["a"]
        assert batch._as_list(back["files"]) == row["files"]
        assert batch._as_list(back["articulations"]) == row["articulations"]


# ---- a real Dask cluster: a scheduler and two workers on 127.0.0.1 -------------------------------


def _port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Cluster:
    def __init__(self, tmp: Path):
        self.port = _port()
        self.address = f"tcp://127.0.0.1:{self.port}"
        self.log = open(tmp / "dask.log", "wb")  # noqa: SIM115 - closed in stop()
        self.procs: list[subprocess.Popen] = []
        dask = str(Path(sys.executable).parent / "dask")
        self.scheduler = self._start([dask, "scheduler", "--host", "127.0.0.1", "--port",
                                      str(self.port), "--no-dashboard"])
        # --no-nanny: the worker is this process, so killing it kills the worker
        self.workers = [self._start([dask, "worker", self.address, "--nthreads", "1",
                                     "--no-nanny", "--no-dashboard", "--host", "127.0.0.1",
                                     "--name", f"w{i}"]) for i in range(2)]
        self._wait_for_workers(2)

    def _start(self, cmd: list[str]) -> subprocess.Popen:
        p = subprocess.Popen(cmd, env=ENV, cwd=ROOT, stdout=self.log, stderr=subprocess.STDOUT)
        self.procs.append(p)
        return p

    def _wait_for_workers(self, n: int, timeout: float = 60.0) -> None:
        from dask.distributed import Client

        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            try:
                with Client(self.address, timeout="5s") as c:
                    if len(c.scheduler_info()["workers"]) >= n:
                        return
            except OSError:
                pass
            time.sleep(0.5)
        raise TimeoutError("the dask workers did not join")

    def stop(self) -> None:
        for p in reversed(self.procs):
            if p.poll() is None:
                os.kill(p.pid, signal.SIGTERM)
        for p in self.procs:
            try:
                p.wait(15)
            except subprocess.TimeoutExpired:
                os.kill(p.pid, signal.SIGKILL)
                p.wait(5)
        self.log.close()


@pytest.fixture
def cluster(tmp_path: Path) -> Iterator[Cluster]:
    c = Cluster(tmp_path)
    yield c
    c.stop()


def test_batch_on_a_scheduler_with_two_workers(tmp_path: Path, cluster: Cluster) -> None:
    out = tmp_path / "out"
    r = cli(spec(tmp_path / "s.json", count=4), "-o", out, "--scheduler", cluster.address)
    assert r.returncode == 0, r.stderr[-3000:]
    rows = manifest(out)
    assert len(rows) == 4 and all(v["status"] == "done" for v in rows.values())


def test_a_worker_killed_mid_batch_loses_nothing(tmp_path: Path, cluster: Cluster) -> None:
    out = tmp_path / "out"
    n = 8
    proc = subprocess.Popen(
        [sys.executable, "-m", "cli.main", "batch", str(spec(tmp_path / "s.json", count=n,
                                                              duration=[1.0, 1.5])),
         "-o", str(out), "--scheduler", cluster.address, "-q"],
        env=ENV, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    from dask.distributed import Client

    try:
        with Client(cluster.address, timeout="10s") as watcher:
            name = {w["name"]: a for a, w in watcher.scheduler_info()["workers"].items()}
            victim_address = name["w0"]
            deadline = time.monotonic() + 300
            while time.monotonic() < deadline:  # rendering, with items of this batch in hand
                if list((out / "audio").glob("*.wav")) and watcher.processing().get(
                        victim_address):
                    break
                time.sleep(0.05)
            in_hand = watcher.processing()[victim_address]
        assert in_hand, "the worker to kill has no item"
        victim = cluster.workers[0]
        os.kill(victim.pid, signal.SIGKILL)
        victim.wait(10)
        stdout, stderr = proc.communicate(timeout=600)
    finally:
        if proc.poll() is None:
            os.kill(proc.pid, signal.SIGKILL)
    assert proc.returncode == 0, stderr[-3000:]
    rows = manifest(out)
    assert sorted(rows) == [f"t-{i:06d}" for i in range(n)]
    assert all(v["status"] == "done" for v in rows.values()), rows
    assert sorted(p.name for p in (out / "audio").iterdir()) == [f"t-{i:06d}.wav"
                                                                  for i in range(n)]
    for v in rows.values():
        x, rate = sf.read(out / v["audio"])
        assert len(x) == round(v["audio_seconds"] * rate)


def test_a_full_disk_fails_the_item_and_leaves_nothing_counted(tmp_path: Path, monkeypatch) -> None:
    import errno

    import soundfile

    def full(path, *args, **kwargs):  # half a file, then the disk is full
        Path(path).write_bytes(b"RIFF\x00\x00")
        raise OSError(errno.ENOSPC, "No space left on device")

    monkeypatch.setattr(soundfile, "write", full)
    out = tmp_path / "out"
    for sub in ("audio", "labels"):
        (out / sub).mkdir(parents=True)
    item = batch.Item(id="x", input="x.json", kind="drawn", scene={
        "duration": 0.2, "quality": "draft",
        "events": [{"type": "pluck", "time": 0.0, "string": 1}]})
    row = batch.render_item(item, str(out), {"format": "wav", "labels": True})
    assert row["status"] == "failed" and "No space left" in row["error"], row
    assert not [p for p in out.rglob("*") if p.is_file()]  # no audio, no labels, no .part
    assert not batch._is_done(row, item, out)


# ---- ids unique by construction; specs drawn lazily ---------------------------------------------


def _pluck_scene(path: Path, string: int) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps({"duration": 0.2, "quality": "draft", "events": [
        {"type": "pluck", "time": 0.0, "string": string, "force": 1.5}]}))
    return path


def test_files_of_one_name_get_ids_no_other_input_has(tmp_path: Path) -> None:
    """``a/x.json b/x.json x-2.json``: the second x may not take x-2, which is the third's."""
    files = [_pluck_scene(tmp_path / "a" / "x.json", 1), _pluck_scene(tmp_path / "b" / "x.json", 2),
             _pluck_scene(tmp_path / "x-2.json", 3), _pluck_scene(tmp_path / "c" / "x.json", 4)]
    items = batch.gather([str(f) for f in files], {}).files
    assert [i.id for i in items] == ["x", "x-3", "x-2", "x-4"]


def test_a_batch_of_clashing_names_writes_a_file_and_row_for_every_input(tmp_path: Path) -> None:
    files = [_pluck_scene(tmp_path / "a" / "x.json", 1), _pluck_scene(tmp_path / "b" / "x.json", 2),
             _pluck_scene(tmp_path / "x-2.json", 3)]
    out = tmp_path / "out"
    r = cli(*files, "-o", out, "--workers", "1", "--no-labels", "--manifest", "parquet")
    assert r.returncode == 0, r.stderr[-3000:]
    rows = manifest(out)
    assert sorted(v["input"] for v in rows.values()) == sorted(map(str, files))
    audio = {(out / v["audio"]).read_bytes() for v in rows.values()}
    assert len(audio) == 3  # three strings: three different files, none overwritten


def test_specs_whose_ids_clash_are_refused_naming_both(tmp_path: Path, capsys) -> None:
    a, b = spec(tmp_path / "a.json"), spec(tmp_path / "b.json")
    assert batch.main([str(a), str(b), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "a.json" in err and "b.json" in err and "'t'" in err
    clash = _pluck_scene(tmp_path / "t-000002.json", 1)
    assert batch.main([str(a), str(clash), "-o", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "t-000002" in err and "a.json" in err


def test_a_spec_of_ten_million_scenes_is_drawn_as_it_is_rendered(tmp_path: Path,
                                                                 monkeypatch) -> None:
    """Gathering draws nothing (the spec allows 10^7 scenes: drawing them first grew memory by
    35 MiB/s with no output); items come one at a time, the scene drawn by the worker."""
    import tracemalloc

    from cli import dataset

    path = spec(tmp_path / "big.json", count=10_000_000)
    real = dataset.draw_scene
    monkeypatch.setattr(dataset, "draw_scene", lambda *a: pytest.fail("drawn while gathering"))
    tracemalloc.start()
    plan = batch.gather([str(path)], {})
    items = plan.items()
    first = [next(items) for _ in range(1000)]
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert plan.total == 10_000_000
    assert peak < 8 * 2**20, peak  # the thousand items made so far, not ten million
    assert [i.id for i in first[:2]] == ["t-000000", "t-000001"] and first[0].scene is None
    monkeypatch.setattr(dataset, "draw_scene", real)
    out = tmp_path / "out"
    for sub in ("audio", "labels"):
        (out / sub).mkdir(parents=True)
    row = batch.render_item(first[1], str(out), {"format": "wav", "labels": False})
    assert row["status"] == "done", row
    x, _ = sf.read(out / row["audio"])
    want = np.clip(np.asarray(engine.render(real(dataset.load_spec(path), 1))), -1, 1)
    assert np.max(np.abs(x - want)) <= 1.0 / 32768
