"""One admission policy for every path, over a real uvicorn process (two workers, renders
estimated over 0.2 s heavy): a score render and a job are admitted by their estimated cost like
/render, heavy renders, heavy scores and jobs together hold at most one worker, a score render
whose client left is stopped, job audio equals /render's byte for byte, and jobs take turns by
client and cost."""

from __future__ import annotations

import json
import socket
import threading
import time
from collections.abc import Iterator

import httpx
import pytest
from conftest import UvicornServer, wait_ready
from svc_helpers import brief, chord_scene, heavy_scene, pluck_scene, same_bytes

from engine.testing.scores import gp5_song


@pytest.fixture(scope="module")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[UvicornServer]:
    tmp = tmp_path_factory.mktemp("admission")
    s = UvicornServer(tmp, {
        "GUITAR_WORKERS": "2", "GUITAR_HEAVY_RENDER_S": "0.2", "GUITAR_DATA_DIR": str(tmp / "data"),
        "GUITAR_API_KEYS": "alice,bob", "GUITAR_JOB_MAX_PER_CLIENT": "4"}).start()
    yield s
    s.stop()


def pool(server: UvicornServer) -> dict:
    return httpx.get(server.url + "/health", timeout=10).json()["pool"]


def wait_job(server: UvicornServer, job_id: str, statuses=("done", "failed", "cancelled"),
             timeout: float = 180.0) -> dict:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        job = httpx.get(f"{server.url}/jobs/{job_id}", timeout=10).json()
        if job["status"] in statuses:
            return job
        time.sleep(0.1)
    raise TimeoutError(f"job {job_id} still {job['status']}")


def idle(server: UvicornServer) -> None:
    wait_ready(lambda: pool(server)["busy"] == 0 and pool(server)["in_flight"] == 0, 120)


# A score that is long and costly at 96 kHz and quality high (eight notes at 40 bpm, 12 s: an
# estimate of about 30 s, within the default budget of 60 s).
SCORE = gp5_song([(1, 5), (2, 5), (3, 5), (1, 7), (2, 7), (3, 7), (1, 8), (2, 8)], tempo=40)
LONG_SCORE = gp5_song([(1, 5), (2, 5), (3, 5), (1, 7), (2, 7), (3, 7), (1, 8), (2, 8)], tempo=25)
SCORE_FORM = {"options": json.dumps({"sample_rate": 96000, "quality": "high"})}


def in_thread(fn) -> tuple[threading.Thread, list]:
    out: list = []
    t = threading.Thread(target=lambda: out.append(fn()), daemon=True)
    t.start()
    return t, out


def test_a_heavy_score_render_takes_a_heavy_slot(server) -> None:
    """/render/score told the pool nothing of its cost: two took both workers."""
    idle(server)
    t, out = in_thread(lambda: httpx.post(server.url + "/render/score", timeout=300,
                                          files={"file": ("s.gp5", SCORE)}, data=SCORE_FORM))
    wait_ready(lambda: pool(server)["heavy_in_flight"] == 1, 60)  # after its import
    assert pool(server)["busy"] == 1
    t.join(300)
    assert out[0].status_code == 200, brief(out[0])


def test_a_job_and_a_heavy_render_never_hold_both_workers(server) -> None:
    """Jobs and heavy renders could each take every worker but one, both at once."""
    idle(server)
    job = httpx.post(server.url + "/jobs", json=heavy_scene(20.0), timeout=30).json()
    wait_job(server, job["id"], ("running",))
    wait_ready(lambda: pool(server)["busy"] == 1, 30)
    t, out = in_thread(lambda: httpx.post(server.url + "/render", json=heavy_scene(2.0),
                                          timeout=300))
    time.sleep(1.0)
    p = pool(server)
    assert p["busy"] == 1 and p["heavy_in_flight"] == 1, p  # it waits for the job's slot
    t0 = time.monotonic()
    r = httpx.post(server.url + "/render", json=pluck_scene(0.1), timeout=60)
    assert r.status_code == 200 and time.monotonic() - t0 < 5.0, brief(r)
    httpx.delete(f"{server.url}/jobs/{job['id']}", timeout=30)
    t.join(300)
    assert out[0].status_code == 200, brief(out[0])


def test_a_heavy_job_and_a_heavy_score_never_hold_both_workers(server) -> None:
    """The same slots across paths: a heavy score render sent while a heavy job renders waits for
    the job's slot (after its import), and a small render is served meanwhile."""
    idle(server)
    job = httpx.post(server.url + "/jobs", json=heavy_scene(20.0), timeout=30).json()
    wait_job(server, job["id"], ("running",))
    wait_ready(lambda: pool(server)["busy"] == 1, 30)
    t, out = in_thread(lambda: httpx.post(server.url + "/render/score", timeout=300,
                                          files={"file": ("s.gp5", SCORE)}, data=SCORE_FORM))
    wait_ready(lambda: pool(server)["heavy_in_flight"] == 1, 60)  # imported, waiting
    time.sleep(1.0)
    p = pool(server)
    assert p["busy"] == 1, p
    t0 = time.monotonic()
    r = httpx.post(server.url + "/render", json=pluck_scene(0.1), timeout=60)
    assert r.status_code == 200 and time.monotonic() - t0 < 5.0, brief(r)
    httpx.delete(f"{server.url}/jobs/{job['id']}", timeout=30)
    t.join(300)
    assert out[0].status_code == 200, brief(out[0])


def test_a_score_render_whose_client_left_is_stopped(server) -> None:
    """It rendered to the end (and the log said 200); now its worker is free within a second or
    two, as for /render, and is the same worker (a heavy render's was killed and replaced)."""
    idle(server)
    replaced = pool(server)["replaced"]
    request = httpx.Request("POST", server.url + "/render/score",
                            files={"file": ("s.gp5", LONG_SCORE)}, data=SCORE_FORM)
    body = request.read()
    head = "".join(f"{k}: {v}\r\n" for k, v in request.headers.items())
    with socket.create_connection(("127.0.0.1", server.port)) as s:
        s.sendall(f"POST /render/score HTTP/1.1\r\n{head}\r\n".encode() + body)
        wait_ready(lambda: pool(server)["busy"] == 1 and pool(server)["heavy_in_flight"] == 1,
                   60)
        time.sleep(0.5)
        assert pool(server)["busy"] == 1  # rendering (19 s at 96 kHz, high: many seconds)
    t0 = time.monotonic()
    wait_ready(lambda: pool(server)["busy"] == 0, 60)
    assert time.monotonic() - t0 < 2.0
    assert pool(server)["replaced"] == replaced


@pytest.mark.parametrize("output", [
    {},  # normalize true, PCM_16
    {"subtype": "PCM_24"},
    {"subtype": "FLOAT"},
    {"channels": 2},
    {"format": "flac", "subtype": "PCM_24"},
    {"format": "flac", "normalize": False},
])
def test_job_audio_is_render_audio_byte_for_byte(server, output) -> None:
    """A normalized job differed from /render by one LSB on some samples (it normalized a float32
    stream); it now scales the raw stream with /render's arithmetic."""
    scene = chord_scene(0.4, output=output)
    job = httpx.post(server.url + "/jobs", json=scene, timeout=30).json()
    done = wait_job(server, job["id"])
    assert done["status"] == "done", done
    got = httpx.get(f"{server.url}/jobs/{job['id']}/audio", timeout=30).content
    want = httpx.post(server.url + "/render", json=scene, timeout=60)
    assert want.status_code == 200, brief(want)
    assert same_bytes(got, want.content), (len(got), len(want.content))


def test_jobs_take_turns_by_client_and_cost(server) -> None:
    """One client's queue of jobs no longer runs ahead of another's job sent just after: the next
    job is the one whose client has been served least (plus its own estimate)."""
    idle(server)
    alice, bob = {"X-API-Key": "alice"}, {"X-API-Key": "bob"}
    post = lambda scene, key: httpx.post(server.url + "/jobs", json=scene, headers=key,  # noqa: E731
                                         timeout=30)
    # the job runner busy first (a job of a third client, seconds), so that all four queue
    # before any is claimed, however fast each one renders
    blocker = httpx.post(server.url + "/jobs", json=heavy_scene(3.0), timeout=30).json()
    wait_job(server, blocker["id"], ("running",))
    a = [post(chord_scene(1.0 + 0.01 * i), alice).json() for i in range(3)]
    b = post(chord_scene(1.0), bob).json()
    assert wait_job(server, blocker["id"])["status"] == "done"
    jobs = {j["id"]: wait_job(server, j["id"]) for j in [*a, b]}
    assert all(j["status"] == "done" for j in jobs.values()), jobs
    order = sorted(jobs, key=lambda k: jobs[k]["started"])
    assert order.index(b["id"]) <= 1, [jobs[k]["started"] for k in order]
    # a client's quota of jobs queued or running, then 429 naming the setting
    more = [post(heavy_scene(10.0), alice) for _ in range(5)]
    assert [r.status_code for r in more] == [202] * 4 + [429], [r.text for r in more]
    assert "GUITAR_JOB_MAX_PER_CLIENT" in more[-1].json()["detail"]
    assert post(pluck_scene(0.1), bob).status_code == 202  # another client is not refused
    for r in more[:4]:
        httpx.delete(f"{server.url}/jobs/{r.json()['id']}", timeout=30)
