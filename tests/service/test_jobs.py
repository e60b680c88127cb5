"""Jobs (service/jobs/): POST /jobs .. DELETE /jobs/{id}, in process (two workers, a temporary
data directory) and as a real uvicorn process killed mid-job and started again."""

from __future__ import annotations

import gc
import os
import signal
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import jams
import numpy as np
import pytest
from conftest import AppHarness, UvicornServer
from svc_helpers import chord_scene, decode, heavy_scene, same_bytes

from engine.testing.scores import gp5_song
from service.config import Settings


@pytest.fixture(scope="module")
def jobs_app(tmp_path_factory: pytest.TempPathFactory) -> Iterator[AppHarness]:
    data = tmp_path_factory.mktemp("jobs-data")
    h = AppHarness(Settings(workers=2, queue_size=8, data_dir=str(data))).start()
    yield h
    h.stop()


def wait_for(get, job_id: str, statuses=("done", "failed", "cancelled"), timeout=120.0) -> dict:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        job = get(f"/jobs/{job_id}").json()
        if job["status"] in statuses:
            return job
        time.sleep(0.1)
    raise TimeoutError(f"job {job_id} still {job['status']}")


def test_a_job_renders_the_stream_s_bytes_and_labels(jobs_app: AppHarness, tmp_path: Path) -> None:
    scene = chord_scene(0.3, output={"normalize": False})
    r = jobs_app.post("/jobs", json=scene)
    assert r.status_code == 202, r.text
    job = r.json()
    assert job["status"] == "queued" and r.headers["location"] == f"/jobs/{job['id']}"
    done = wait_for(jobs_app.get, job["id"])
    assert done["status"] == "done" and done["progress"] == 1.0, done
    assert done["audio_seconds"] == pytest.approx(0.3)
    a = jobs_app.get(f"/jobs/{job['id']}/audio")
    assert a.status_code == 200 and a.headers["content-type"] == "audio/wav"
    # the same bytes as /render/stream (and /render with normalize false) for the scene
    ref = jobs_app.post("/render", json=scene)
    assert same_bytes(a.content, ref.content)
    if done["labels"]:
        lab = jobs_app.get(f"/jobs/{job['id']}/labels")
        assert lab.status_code == 200
        notes = jams.JAMS.loads(lab.text).search(namespace="note_midi")
        assert sum(len(n.data) for n in notes) >= 5  # five plucked strings and a tap
    else:
        pytest.fail(f"no labels: {done['labels_error']}")


def test_a_job_s_slow_disk_never_stalls_the_event_loop(jobs_app: AppHarness,
                                                        monkeypatch: pytest.MonkeyPatch) -> None:
    """The job's writes and its fsync ran on the event loop: a disk that took seconds to sync
    (tens of MB of a song's samples, other writers) stalled every request of the process, and
    live sessions' blocks with them, for as long.  Here a sync takes 1.5 s."""
    import service.jobs.runner as runner

    real = os.fsync
    monkeypatch.setattr(runner.os, "fsync", lambda fd: (time.sleep(1.5), real(fd)))
    r = jobs_app.post("/jobs", json=chord_scene(0.3))
    assert r.status_code == 202, r.text
    waits = []
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        t0 = time.monotonic()
        status = jobs_app.get(f"/jobs/{r.json()['id']}").json()["status"]
        jobs_app.get("/health/live")
        waits.append(time.monotonic() - t0)
        if status in ("done", "failed", "cancelled"):
            break
        time.sleep(0.02)
    assert status == "done"
    assert max(waits) < 0.75, max(waits)  # two requests, never behind a 1.5 s sync


def test_a_normalized_wav_job_peaks_at_minus_1_dbfs(jobs_app: AppHarness) -> None:
    r = jobs_app.post("/jobs", json=chord_scene(0.2, output={"subtype": "PCM_24"}))
    done = wait_for(jobs_app.get, r.json()["id"])
    assert done["status"] == "done", done
    x, rate, info = decode(jobs_app.get(done["audio_url"]).content)
    assert info.subtype == "PCM_24" and len(x) == round(0.2 * 44100)
    assert 20 * np.log10(np.max(np.abs(x))) == pytest.approx(-1.0, abs=0.01)


def test_flac_job(jobs_app: AppHarness) -> None:
    r = jobs_app.post("/jobs", json=chord_scene(0.2, output={"format": "flac"}))
    done = wait_for(jobs_app.get, r.json()["id"])
    assert done["status"] == "done", done
    a = jobs_app.get(f"/jobs/{done['id']}/audio")
    x, rate, info = decode(a.content)
    assert info.format == "FLAC" and len(x) == round(0.2 * 44100)


def test_a_score_job(jobs_app: AppHarness) -> None:
    data = gp5_song([(3, 0), (2, 1), (1, 0), (2, 3)])  # four quarter notes at 120 bpm: 2 s
    r = jobs_app.post("/jobs", files={"file": ("tune.gp5", data)},
                      data={"options": '{"max_seconds": 1.5}', "output": '{"format": "flac"}'})
    assert r.status_code == 202, r.text
    done = wait_for(jobs_app.get, r.json()["id"])
    assert done["status"] == "done" and done["format"] == "flac", done
    x, rate, info = decode(jobs_app.get(done["audio_url"]).content)
    assert info.format == "FLAC" and len(x) == round(1.5 * rate)
    assert done["labels"], done["labels_error"]
    r = jobs_app.post("/jobs", files={"file": ("tune.gp5", data)}, data={"options": '{"bpm": 1}'})
    assert r.status_code == 422 and r.json()["detail"][0]["field"].startswith("options"), r.text


def test_unknown_job_is_404_everywhere(jobs_app: AppHarness) -> None:
    for method, url in (("GET", "/jobs/nope"), ("GET", "/jobs/nope/audio"),
                        ("GET", "/jobs/nope/labels"), ("DELETE", "/jobs/nope")):
        r = jobs_app.request(method, url)
        assert r.status_code == 404, (method, url, r.status_code)
        assert "nope" in r.json()["detail"]


def test_bad_scene_and_job_limits_are_422_naming_the_field(jobs_app: AppHarness) -> None:
    r = jobs_app.post("/jobs", json={"duration": -1, "events": []})
    assert r.status_code == 422 and r.json()["detail"][0]["field"] == "duration"
    r = jobs_app.post("/jobs", json={"duration": 700.0, "events": []})
    assert r.status_code == 422
    assert "GUITAR_JOB_MAX_DURATION_S" in r.json()["detail"][0]["message"]
    r = jobs_app.post("/jobs", content=b'{"duration": NaN}',
                      headers={"content-type": "application/json"})
    assert r.status_code == 422
    r = jobs_app.post("/jobs", files={"file": ("x.gp5", b"not a score")})
    assert r.status_code == 422 and r.json()["detail"][0]["field"] == "file"


def test_a_job_over_its_cost_budget_is_refused_naming_the_setting(jobs_app: AppHarness) -> None:
    """Jobs had no cost check: any scene up to 600 s was queued, with a time limit of 50 minutes.
    A scene estimated over GUITAR_JOB_MAX_RENDER_S (600 s of rendering) is now a short 422 that
    says how long it may be at these settings."""
    r = jobs_app.post("/jobs", json=heavy_scene(600.0))
    assert r.status_code == 422 and len(r.content) < 4096, (r.status_code, len(r.content))
    (d,) = r.json()["detail"]
    assert d["field"] == "duration" and "GUITAR_JOB_MAX_RENDER_S" in d["message"], d
    most = float(d["message"].split("at most ")[2].split(" s")[0])
    assert 0 < most < 600.0
    assert jobs_app.post("/jobs", json=heavy_scene(most * 1.05)).status_code == 422
    ok = jobs_app.post("/jobs", json=heavy_scene(most * 0.01))
    assert ok.status_code == 202, ok.text
    jobs_app.request("DELETE", f"/jobs/{ok.json()['id']}")


def test_cancel_a_running_job_frees_its_worker(jobs_app: AppHarness) -> None:
    job = jobs_app.post("/jobs", json=heavy_scene(30.0)).json()
    wait_for(jobs_app.get, job["id"], ("running",))
    r = jobs_app.request("DELETE", f"/jobs/{job['id']}")
    assert r.status_code == 200 and r.json()["status"] == "cancelled"
    deadline = time.monotonic() + 10
    while jobs_app.get("/health").json()["pool"]["busy"] and time.monotonic() < deadline:
        time.sleep(0.05)
    assert jobs_app.get("/health").json()["pool"]["busy"] == 0
    assert jobs_app.get(f"/jobs/{job['id']}").json()["status"] == "cancelled"
    assert jobs_app.get(f"/jobs/{job['id']}/audio").status_code == 409
    # a finished job is deleted with its results
    assert jobs_app.request("DELETE", f"/jobs/{job['id']}").status_code == 204
    assert jobs_app.get(f"/jobs/{job['id']}").status_code == 404


def test_a_long_job_leaves_a_worker_to_render(jobs_app: AppHarness) -> None:
    long_jobs = [jobs_app.post("/jobs", json=heavy_scene(20.0)).json() for _ in range(2)]
    wait_for(jobs_app.get, long_jobs[0]["id"], ("running",))
    t0 = time.perf_counter()
    r = jobs_app.post("/render", json=chord_scene(0.2))
    assert r.status_code == 200
    assert time.perf_counter() - t0 < 5.0  # not behind 20 s jobs
    assert jobs_app.get(f"/jobs/{long_jobs[1]['id']}").json()["status"] == "queued"
    for j in long_jobs:
        jobs_app.request("DELETE", f"/jobs/{j['id']}")


def test_metrics(jobs_app: AppHarness) -> None:
    jobs_app.post("/render", json=chord_scene(0.2))
    jobs_app.get("/jobs/some-id")
    text = jobs_app.get("/metrics").text
    for name in ("guitar_renders_total", "guitar_render_seconds_bucket", "guitar_jobs{",
                 "guitar_queue_depth", "guitar_worker_restarts_total", "guitar_workers_ready"):
        assert name in text, name
    line = next(x for x in text.splitlines()
                if x.startswith('guitar_renders_total{endpoint="/render",outcome="ok"}'))
    assert float(line.split()[-1]) >= 1
    assert 'guitar_http_requests_total{method="GET",route="/jobs/{id}",status="404"}' in text


def test_the_event_loop_s_lag_is_measured(jobs_app: AppHarness) -> None:
    """guitar_event_loop_lag_seconds: a probe every 0.1 s; a loop held for 0.6 s shows in the
    buckets above 0.25 s."""
    def over_quarter() -> float:
        text = jobs_app.get("/metrics").text
        count = next(float(x.split()[-1]) for x in text.splitlines()
                     if x.startswith("guitar_event_loop_lag_seconds_count"))
        le = next(float(x.split()[-1]) for x in text.splitlines()
                  if x.startswith('guitar_event_loop_lag_seconds_bucket{le="0.25"}'))
        return count - le

    before = over_quarter()

    async def hold_the_loop() -> None:
        time.sleep(0.6)  # noqa: ASYNC251 - a stall on purpose

    jobs_app.run(hold_the_loop())
    time.sleep(0.3)
    assert over_quarter() == before + 1


def test_the_garbage_collector_s_pauses_are_measured(jobs_app: AppHarness) -> None:
    """guitar_gc_pause_seconds: every collection, by generation; and what the app held when it
    had started is frozen out of the collector's sight (gc.freeze)."""
    assert gc.get_freeze_count() > 0

    def full_collections() -> float:
        return next((float(x.split()[-1]) for x in jobs_app.get("/metrics").text.splitlines()
                     if x.startswith('guitar_gc_pause_seconds_count{generation="2"}')), 0.0)

    before = full_collections()

    async def collect() -> None:
        gc.collect()

    jobs_app.run(collect())
    assert full_collections() >= before + 1


def test_retention_deletes_old_results(tmp_path: Path) -> None:
    from service.jobs.store import Store

    store = Store(tmp_path)
    jobs = [store.create({"duration": 1.0}, "wav", 1.0) for _ in range(3)]
    for j in jobs:
        assert store.claim_next()["id"] == j["id"]
        store.job_dir(j["id"]).mkdir()
        store.finish(j["id"], "done")
    (store.results / "orphan").mkdir()
    assert store.cleanup(retention_s=3600, max_jobs=2) == [jobs[0]["id"]]  # the oldest
    assert not store.job_dir(jobs[0]["id"]).exists() and not (store.results / "orphan").exists()
    time.sleep(0.01)
    assert sorted(store.cleanup(retention_s=0.001, max_jobs=10)) == sorted(
        j["id"] for j in jobs[1:])
    store.close()


def test_the_store_s_disk_syncs_happen_in_its_checkpoint_only(tmp_path: Path) -> None:
    """SQLite's automatic checkpoint synced the database inside whichever commit filled the WAL,
    on the event loop; commits now only append to the WAL, and ``checkpoint`` (called from a
    thread by the runner) copies it, while the store is in use."""
    from service.jobs.store import Store

    store = Store(tmp_path)
    scene = {"duration": 1.0, "events": [{"type": "pluck", "time": 0.0, "string": 1}] * 2000}
    for _ in range(40):  # about 5 MB of scenes: past SQLite's default 1000-page checkpoint
        store.create(scene, "wav", 1.0)
    wal = tmp_path / "jobs.sqlite3-wal"
    assert wal.stat().st_size > 4_000_000  # nothing checkpointed on the way
    busy, frames, done = store.checkpoint()
    assert busy == 0 and frames == done > 1000, (busy, frames, done)
    assert store.total() == 40
    store.close()


def test_killed_service_finishes_the_job_after_restart(tmp_path: Path) -> None:
    env = {"GUITAR_WORKERS": "1", "GUITAR_DATA_DIR": str(tmp_path / "data")}
    scene = heavy_scene(12.0)
    scene["output"] = {"normalize": False}
    s = UvicornServer(tmp_path, env).start()
    try:
        job = httpx.post(s.url + "/jobs", json=scene, timeout=30).json()
        deadline = time.monotonic() + 60
        while True:
            now = httpx.get(f"{s.url}/jobs/{job['id']}", timeout=10).json()
            if now["status"] == "running" and now["progress"] > 0.05 or time.monotonic() > deadline:
                break
            time.sleep(0.1)
        assert now["status"] == "running" and now["progress"] < 0.9, now
        os.kill(s.proc.pid, signal.SIGKILL)  # no shutdown at all: the job is left "running"
        s.proc.wait(10)
    finally:
        s.stop()
    s2 = UvicornServer(tmp_path, env).start()
    try:
        done = wait_for(lambda url: httpx.get(s2.url + url, timeout=10), job["id"], timeout=180)
        assert done["status"] == "done" and done["attempts"] == 2, done
        a = httpx.get(f"{s2.url}/jobs/{job['id']}/audio", timeout=30)
        x, rate, info = decode(a.content)
        assert (rate, len(x)) == (96000, 12 * 96000)
        assert not list((tmp_path / "data" / "results" / job["id"]).glob("*.part"))
    finally:
        s2.stop()


def test_sigterm_leaves_a_running_job_queued_with_its_attempt_uncounted(tmp_path: Path) -> None:
    env = {"GUITAR_WORKERS": "1", "GUITAR_DATA_DIR": str(tmp_path / "data")}
    s = UvicornServer(tmp_path, env).start()
    job = httpx.post(s.url + "/jobs", json=heavy_scene(30.0), timeout=30).json()
    wait_for(lambda url: httpx.get(s.url + url, timeout=10), job["id"], ("running",))
    t0 = time.monotonic()
    s.stop()  # SIGTERM
    assert time.monotonic() - t0 < 15
    import sqlite3

    db = sqlite3.connect(tmp_path / "data" / "jobs.sqlite3")
    status, attempts = db.execute("SELECT status, attempts FROM jobs WHERE id = ?",
                                  (job["id"],)).fetchone()
    db.close()
    assert (status, attempts) == ("queued", 0)


def test_a_job_streams_its_wav_while_it_renders(jobs_app: AppHarness) -> None:
    """GET /jobs/{id}/stream, asked for at once (the job still queued): the whole file, the
    bytes GET /jobs/{id}/audio gives once done; a Range is answered 206 with its slice; a
    normalized job (its file rewritten at the end) is 409."""
    scene = chord_scene(0.6, output={"normalize": False})
    job = jobs_app.post("/jobs", json=scene).json()
    whole = jobs_app.get(f"/jobs/{job['id']}/stream", timeout=120.0)
    assert whole.status_code == 200 and whole.headers["accept-ranges"] == "bytes"
    assert wait_for(jobs_app.get, job["id"])["status"] == "done"
    assert whole.content == jobs_app.get(f"/jobs/{job['id']}/audio").content
    part = jobs_app.get(f"/jobs/{job['id']}/stream", headers={"range": "bytes=1000-1999"})
    assert part.status_code == 206 and part.content == whole.content[1000:2000]
    assert part.headers["content-range"] == f"bytes 1000-1999/{len(whole.content)}"
    tail = jobs_app.get(f"/jobs/{job['id']}/stream", headers={"range": "bytes=-10"})
    assert tail.status_code == 206 and tail.content == whole.content[-10:]
    bad = jobs_app.get(f"/jobs/{job['id']}/stream", headers={"range": f"bytes={len(whole.content)}-"})
    assert bad.status_code == 416
    normalized = jobs_app.post("/jobs", json=chord_scene(0.3)).json()
    r = jobs_app.get(f"/jobs/{normalized['id']}/stream")
    assert r.status_code == 409 and "normalize" in r.json()["detail"]
    assert jobs_app.get("/jobs/nope/stream").status_code == 404
