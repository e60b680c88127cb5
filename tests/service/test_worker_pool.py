"""The worker pool under load and failure: concurrency, 503 when full, 504 past the time limit,
recovery after a worker is killed mid-render."""

from __future__ import annotations

import asyncio
import os
import signal
import time
from types import SimpleNamespace

import pytest
from conftest import AppHarness
from svc_helpers import brief, chord_scene, decode, heavy_scene, pluck_scene, same_bytes

from service.config import Settings
from service.exceptions import PoolBusy
from service.pool import WorkerPool


def wait_for(check, timeout: float = 30.0) -> None:
    deadline = time.monotonic() + timeout
    while not check():
        if time.monotonic() > deadline:
            raise TimeoutError("condition not met")
        time.sleep(0.02)


def test_concurrent_requests_all_succeed_and_agree(harness) -> None:
    scenes = [chord_scene(0.2), pluck_scene(0.2, string=6)] * 4

    async def many():
        return await asyncio.gather(*(harness.client.post("/render", json=s) for s in scenes))

    responses = harness.run(many())
    assert [r.status_code for r in responses] == [200] * len(scenes)
    # Deterministic whichever worker rendered it.
    assert len({r.content for r in responses[0::2]}) == 1
    assert len({r.content for r in responses[1::2]}) == 1
    assert not same_bytes(responses[0].content, responses[1].content)


def test_renders_run_in_worker_processes(harness) -> None:
    pids = harness.pool.pids()
    assert len(pids) == 2 and os.getpid() not in pids


def test_overload_is_answered_503_with_retry_after(tiny_harness) -> None:
    h = tiny_harness  # one worker, no queue

    async def overload():
        first = asyncio.ensure_future(h.client.post("/render", json=heavy_scene(1.0)))
        while not h.pool.busy_pids():  # the only worker has taken the first render
            await asyncio.sleep(0.01)
        second = await h.client.post("/render", json=pluck_scene(0.05))
        return second, await first

    second, first = h.run(overload())
    assert second.status_code == 503
    assert second.headers["retry-after"] == "3"
    assert "busy" in second.json()["detail"]
    assert first.status_code in (200, 504)  # admitted: served or stopped by the time limit
    # Capacity is back once the first one is done (and, after a 504, its worker replaced).
    wait_for(lambda: h.get("/health/ready").status_code == 200)
    again = h.post("/render", json=pluck_scene(0.05))
    assert again.status_code == 200, brief(again)


def test_time_limit_gives_504_and_the_pool_recovers(tiny_harness) -> None:
    h = tiny_harness  # time limit 0.5 s
    replaced = h.pool.status()["replaced"]
    old_pid = h.pool.pids()[0]
    t0 = time.monotonic()
    r = h.post("/render", json=heavy_scene(20.0))  # seconds of work, far past the limit
    elapsed = time.monotonic() - t0
    assert r.status_code == 504, brief(r)
    assert "time limit" in r.json()["detail"]
    assert elapsed < 3.0  # stopped at the limit, not run to the end
    # The killed worker is replaced; the next render succeeds on the new one.
    wait_for(lambda: h.get("/health/ready").status_code == 200)
    ok = h.post("/render", json=pluck_scene(0.05))
    assert ok.status_code == 200
    assert h.pool.status()["replaced"] == replaced + 1
    assert h.pool.pids()[0] != old_pid


def test_stream_past_its_time_limit_before_its_first_block_gives_504(tiny_harness) -> None:
    # tiny_harness streams in blocks of 2^20 frames: the first block is the whole render, which
    # cannot finish in 0.5 s, so the failure comes before any header and can still be a status.
    h = tiny_harness
    wait_for(lambda: h.get("/health/ready").status_code == 200)
    r = h.post("/render/stream", json=heavy_scene(6.0))
    assert r.status_code == 504, brief(r)
    assert "time limit" in r.json()["detail"]
    wait_for(lambda: h.get("/health/ready").status_code == 200)
    assert h.post("/render/stream", json=pluck_scene(0.05)).status_code == 200


def test_killed_worker_gives_502_others_unaffected_pool_recovers(harness) -> None:
    h = harness
    wait_for(lambda: h.pool.status()["workers_ready"] == 2)
    replaced = h.pool.status()["replaced"]

    async def kill_one_of_two():
        # estimated under GUITAR_HEAVY_RENDER_S: two such renders may run at once on two workers
        a = asyncio.ensure_future(h.client.post("/render", json=heavy_scene(1.0)))
        b = asyncio.ensure_future(h.client.post("/render", json=heavy_scene(1.0)))
        while len(h.pool.busy_pids()) < 2:
            await asyncio.sleep(0.01)
        victim = h.pool.busy_pids()[0]
        os.kill(victim, signal.SIGKILL)
        return victim, await a, await b

    victim, a, b = h.run(kill_one_of_two())
    statuses = sorted([a.status_code, b.status_code])
    assert statuses == [200, 502], (brief(a), brief(b))
    failed = a if a.status_code == 502 else b
    assert "worker died" in failed.json()["detail"]
    ok = b if failed is a else a
    x, _, _ = decode(ok.content)
    assert len(x) == round(1.0 * 96000)
    # The pool replaces the worker by itself; a later request succeeds.
    wait_for(lambda: h.pool.status()["workers_ready"] == 2)
    assert victim not in h.pool.pids()
    assert h.pool.status()["replaced"] == replaced + 1
    assert h.post("/render", json=pluck_scene(0.1)).status_code == 200


def test_idle_worker_killed_is_replaced(harness) -> None:
    h = harness
    wait_for(lambda: h.pool.status()["workers_ready"] == 2)
    victim = h.pool.pids()[0]
    os.kill(victim, signal.SIGKILL)
    wait_for(lambda: victim not in h.pool.pids() and h.pool.status()["workers_ready"] == 2)
    responses = [h.post("/render", json=pluck_scene(0.05)) for _ in range(4)]
    assert all(r.status_code == 200 for r in responses)


def test_health_reports_pool_state(harness) -> None:
    body = harness.get("/health").json()
    assert body["status"] == "ok" and body["ready"] is True
    assert body["pool"]["workers"] == 2 and body["pool"]["capacity"] == 10


def test_a_wait_that_runs_out_while_the_workers_start_says_so() -> None:
    """A request that comes before the workers have compiled or loaded the kernels waits for one
    (``queue_timeout_s``); if none is ready by then, the 503 says why (a fresh machine compiles
    for about a minute) and points at /health, which a full pool's 503 does not."""
    pool = WorkerPool(Settings(workers=2, queue_size=0, queue_timeout_s=0.05))
    pool._workers = [SimpleNamespace(ready=False), SimpleNamespace(ready=True)]

    async def wait():
        pool.loop = asyncio.get_running_loop()
        with pytest.raises(PoolBusy, match=r"still starting \(1 of 2 ready.*/health"):
            await pool._acquire()
        pool._warm = True  # started once: a later timeout is a busy pool
        with pytest.raises(PoolBusy) as busy:
            await pool._acquire()
        assert "starting" not in str(busy.value)

    asyncio.run(wait())


def test_health_says_what_a_warming_worker_is_doing() -> None:
    """A worker compiling the kernels (a machine's first start) says so; /health's pool shows
    it until the worker is ready."""
    pool = WorkerPool(Settings(workers=1))
    w = SimpleNamespace(number=1, pid=123, alive=True, ready=False, warmed=False, job=None,
                        warming=None)
    pool._workers = [w]
    pool._responsive = lambda w: w.ready
    assert pool.status()["warming"] is None
    pool._on_message(w, ("warming", 123, "compiling kernels, first run only"))
    assert pool.status()["warming"] == "compiling kernels, first run only"
    pool._on_message(w, ("ready", 123, 42.0, 90_000))
    assert pool.status()["warming"] is None


# ---- who gets a worker that comes free ----------------------------------------------------------

def test_a_free_worker_goes_to_the_cheapest_waiting_request_then_to_the_oldest() -> None:
    """Waiting requests took workers first come, first served: a 0.1 s render waited behind a
    4 s one that came a moment before it.  Now the least ``cost - seconds waited`` goes first."""
    pool = WorkerPool(Settings(workers=1, queue_timeout_s=5.0))
    w = SimpleNamespace(alive=True, ready=True, job=None)
    pool._responsive = lambda w: True

    async def scenario():
        pool.loop = asyncio.get_running_loop()
        order: list[str] = []

        async def want(name: str, cost: float) -> None:
            got = await pool._acquire(cost=cost)
            order.append(name)
            pool.loop.call_soon(pool._free, got)  # done at once: the next waiter's turn

        async def race(first: tuple, second: tuple, waited_s: float = 0.0) -> list[str]:
            """Two requests wait (the first for ``waited_s`` more), then one worker comes free."""
            order.clear()
            a = asyncio.ensure_future(want(*first))
            await asyncio.sleep(0.01)
            pool._waiters[0].since -= waited_s
            b = asyncio.ensure_future(want(*second))
            await asyncio.sleep(0.01)
            pool._free(w)
            await asyncio.gather(a, b)
            await asyncio.sleep(0.01)
            assert pool._idle == [w]  # back once nobody waits
            pool._idle.clear()
            return list(order)

        assert await race(("4 s", 4.0), ("0.1 s", 0.1)) == ["0.1 s", "4 s"]
        # waiting counts: a 1 s request that has waited 2 s goes before a fresh 0.5 s one
        assert await race(("1 s, waited", 1.0), ("0.5 s, new", 0.5), 2.0) == [
            "1 s, waited", "0.5 s, new"]
        # a waiter that gave up (timed out, client gone) never swallows the worker
        gone = asyncio.ensure_future(want("gone", 0.0))
        await asyncio.sleep(0.01)
        gone.cancel()
        await asyncio.sleep(0.01)
        pool._free(w)
        assert pool._idle == [w] and not pool._waiters

    asyncio.run(scenario())


@pytest.fixture(scope="module")
def one_worker(tmp_path_factory: pytest.TempPathFactory):
    """One worker that any render may hold (no heavy class), a queue of four."""
    h = AppHarness(Settings(workers=1, queue_size=4, heavy_render_s=1000.0,
                            data_dir=str(tmp_path_factory.mktemp("one-worker-data")))).start()
    yield h
    h.stop()


def test_a_small_render_waits_behind_the_running_one_only(one_worker) -> None:
    """Over HTTP, with one worker: a small render sent after a larger one that waits is served
    before it (each route tells the pool its render's estimate)."""
    h = one_worker
    wait_for(lambda: h.pool.status()["workers_ready"] == 1)

    async def run():
        done: list[str] = []

        async def post(name: str, scene: dict) -> int:
            r = await h.client.post("/render", json=scene)
            done.append(name)
            return r.status_code

        async def until(check) -> None:
            for _ in range(3000):
                if check():
                    return
                await asyncio.sleep(0.01)
            raise TimeoutError(h.pool.status())

        running = asyncio.ensure_future(post("running", heavy_scene(3.0)))
        await until(h.pool.busy_pids)
        larger = asyncio.ensure_future(post("larger", heavy_scene(2.0)))
        await until(lambda: h.pool.status()["in_flight"] == 2)
        small = asyncio.ensure_future(post("small", pluck_scene(0.1)))
        await until(lambda: h.pool.status()["in_flight"] == 3)
        codes = await asyncio.gather(running, larger, small)
        return codes, done

    codes, done = h.run(run(), timeout=180)
    assert codes == [200, 200, 200]
    assert done == ["running", "small", "larger"], done


def test_a_job_of_any_cost_takes_a_heavy_slot() -> None:
    """A job estimated under ``heavy_render_s`` took no heavy slot: with a heavy render beside
    it, both workers were held and small renders waited.  Now every job takes one, so a heavy
    render waits for it and a small render finds the other worker."""
    pool = WorkerPool(Settings(workers=2, queue_timeout_s=0.2))
    sent: list[tuple] = []
    workers = [SimpleNamespace(number=i, pid=i, alive=True, ready=True, job=None,
                               send=lambda msg, i=i: sent.append((i, msg[0])))
               for i in (1, 2)]
    pool._responsive = lambda w: True

    async def scenario():
        pool.loop = asyncio.get_running_loop()
        pool._idle = list(workers)
        job = asyncio.ensure_future(pool.job_stream({}, 60.0, cost=0.01))
        await asyncio.sleep(0.05)
        assert sent == [(1, "stream")] and pool._heavy_running.locked()
        with pytest.raises(PoolBusy, match="heavy"):
            await pool.render({}, 60.0, heavy=True, cost=10.0)
        small = asyncio.ensure_future(pool.render({}, 60.0, cost=0.1))
        await asyncio.sleep(0.05)
        assert sent[-1] == (2, "render")
        for t in (job, small):
            t.cancel()
        await asyncio.gather(job, small, return_exceptions=True)

    asyncio.run(scenario())
