"""A small pool of render worker processes that survives the death of any one of them.

Why not ``concurrent.futures.ProcessPoolExecutor``: when one of its workers dies (killed for running
past its time limit, or by the OOM killer) the whole executor is broken and every queued future
fails.  Here each worker is a ``multiprocessing`` process (spawn/forkserver, never fork: the parent
runs an event loop and threads) with its own duplex pipe, so one worker can be killed and replaced
while the others carry on.  Streaming needs the same pipe: a worker sends each block as it is made.

Threads and the loop: each worker has a reader thread that blocks on its pipe and hands every
message to the event loop (``call_soon_threadsafe``); all pool state is touched on the loop only.
A worker's death shows up as end-of-file on its pipe, whatever killed it.

Admission: at most ``workers + queue_size`` renders are in flight (running or waiting); more are
refused at once (``PoolBusy`` -> 503 with Retry-After).  A heavy render (its cost estimate above
``heavy_render_s``) also needs one of ``heavy_slots`` (all workers but one by default) and may
wait for one only in a queue of its own (``heavy_queue_size``); every job of ``service.jobs``
takes one of those slots too, whatever its cost: two maximal renders, or a job and a heavy
render, cannot hold every worker while small renders wait.  Each job has a deadline armed when it
is dispatched; past it the worker is killed (``RenderTimeout`` -> 504) and replaced.

Order: a worker that comes free goes to the waiting request of least ``cost - waited`` (its
estimated render seconds less the seconds it has waited, ``_Waiter.rank``): the cheapest first,
so a 0.1 s render does not wait behind a 4 s one that came a moment earlier, and none starves, as
every second of waiting counts as a second less of cost.

Liveness: every worker sends a heartbeat each ``heartbeat_s`` from a thread of its own (it beats
while the main thread renders); a worker not heard from for ``_STALE_BEATS`` periods is not
counted ready, and one silent for ``heartbeat_timeout_s`` (stopped, deadlocked) is killed and
replaced by the watchdog, with its job answered as a worker death (502).
"""

from __future__ import annotations

import asyncio
import itertools
import logging
import multiprocessing as mp
import time
from collections.abc import AsyncIterator, Callable
from dataclasses import dataclass, field
from typing import Any

from . import worker as worker_module
from .config import Settings
from .exceptions import (
    PoolBusy,
    PoolClosed,
    PoolError,
    RenderFailed,
    RenderTimeout,
    StreamAborted,
    WorkerDied,
)
from .processes import PipedProcess, stop_all

log = logging.getLogger("service.pool")

_TERMINAL = frozenset({"done", "end", "cancelled", "error"})
_CANCEL_GRACE_S = 5.0  # a cancelled stream's worker that has not stopped by then is killed
_RESPAWN_BACKOFF_MAX_S = 30.0
_START_GRACE_S = 60.0  # a new worker process may take this long to send its first heartbeat
_STALE_BEATS = 3.0  # a ready worker silent for this many heartbeat periods is not counted ready


@dataclass
class RenderOutput:
    data: bytes
    render_seconds: float
    frames: int
    energy_error: float | None
    warnings: list[str]


@dataclass
class _Waiter:
    """A request waiting for a worker: its estimated render seconds and when it began to wait."""
    cost: float
    since: float
    future: asyncio.Future

    def rank(self, now: float) -> float:
        return self.cost - (now - self.since)


@dataclass
class _Job:
    id: int
    kind: str
    messages: asyncio.Queue = field(default_factory=asyncio.Queue)
    worker: _Worker | None = None
    timer: asyncio.TimerHandle | None = None
    finished: bool = False
    on_finish: Callable[[], None] | None = None  # frees the admission slot of a render
    heavy: bool = False
    cleanup: list[Callable[[], None]] = field(default_factory=list)  # e.g. frees a heavy slot


class _Worker(PipedProcess):
    """A render worker: its job, and what it last said (heartbeats included)."""

    def __init__(self, pool: WorkerPool, ctx: Any, number: int):
        self.last_seen = time.monotonic()  # any message, heartbeats included (set by the reader)
        self.heard = False  # a first message came (the process is up and its heartbeat runs)
        self.warmed = False  # said "ready" once (``ready`` goes False when it is being killed)
        self.job: _Job | None = None
        self.jobs_done = 0
        self.warming: str | None = None  # what its warm-up is doing, until it is ready
        s = pool.settings
        super().__init__(pool, ctx, number, worker_module.main,
                         (s.warmup, s.stream_block_frames, s.heartbeat_s, s.worker_nice,
                          s.render_threads),
                         f"render-worker-{number}")
        self.last_seen = self.started

    def received(self, msg: Any) -> bool:
        self.last_seen = time.monotonic()
        self.heard = True
        return msg[0] != "beat"

    def silent_for(self) -> float:
        return time.monotonic() - self.last_seen

    def hung(self, timeout_s: float) -> bool:
        """Silent for ``timeout_s`` since its last message; a process not heard from yet (Python
        starting, imports) gets ``_START_GRACE_S`` first."""
        if not self.heard:
            return self.silent_for() > max(timeout_s, _START_GRACE_S)
        return self.silent_for() > timeout_s


class WorkerPool:
    def __init__(self, settings: Settings):
        self.settings = settings
        self.size = settings.workers
        self.capacity = settings.workers + settings.queue_size
        self.loop: asyncio.AbstractEventLoop
        self._ctx = mp.get_context(settings.mp_context)
        self._workers: list[_Worker] = []
        self._idle: list[_Worker] = []  # free workers, when nobody waits for one
        self._waiters: list[_Waiter] = []
        self._numbers = itertools.count(1)
        self._job_ids = itertools.count(1)
        self._in_flight = 0
        self._warm = False  # every worker of the first generation has warmed up
        self._closing = False
        self._failed_starts = 0
        self.replaced = 0
        self.hung = 0
        self.heavy_slots = settings.heavy_slots()
        self.heavy_capacity = self.heavy_slots + settings.heavy_queue_size
        self._heavy_running = asyncio.Semaphore(self.heavy_slots)
        self._heavy_in_flight = 0
        self._watchdog: asyncio.Task | None = None

    # ---- life cycle -------------------------------------------------------------------------

    async def start(self) -> None:
        """Start the workers; they warm up in the background (``ready`` tells when done)."""
        self.loop = asyncio.get_running_loop()
        for _ in range(self.size):
            self._spawn()
        self._watchdog = self.loop.create_task(self._watch())

    async def close(self, timeout_s: float = 5.0) -> None:
        self._closing = True
        if self._watchdog is not None:
            self._watchdog.cancel()
        await stop_all(self._workers, timeout_s)

    def _spawn(self) -> None:
        w = _Worker(self, self._ctx, next(self._numbers))
        self._workers.append(w)
        log.info("worker started", extra={"fields": {"worker": w.number, "pid": w.pid}})

    def _responsive(self, w: _Worker) -> bool:
        """Ready, and heard from lately (a stopped or hung worker stops its heartbeats)."""
        return w.alive and w.ready and w.silent_for() < _STALE_BEATS * self.settings.heartbeat_s

    @property
    def ready(self) -> bool:
        """A worker can take a render now (``/health/ready``)."""
        return self._warm and any(self._responsive(w) for w in self._workers)

    @property
    def healthy(self) -> bool:
        """Warmed up once and some worker process is alive: ready, a replacement warming up, or
        a hung one about to be replaced.  The pool heals itself (the watchdog kills what hangs,
        an exit is replaced at once), so a replacement in progress is no failure (``/health``);
        no process at all (replacements failing to start, in back-off) is."""
        return self._warm and not self._closing and any(w.alive for w in self._workers)

    def status(self) -> dict[str, Any]:
        return {
            "workers": self.size,
            "workers_ready": sum(self._responsive(w) for w in self._workers),
            "busy": sum(w.job is not None for w in self._workers),
            "in_flight": self._in_flight,
            "capacity": self.capacity,
            "replaced": self.replaced,
            "heavy_in_flight": self._heavy_in_flight,
            "heavy_capacity": self.heavy_capacity,
            "hung": self.hung,
            "warming": next((w.warming for w in self._workers if w.alive and w.warming), None),
        }

    async def _watch(self) -> None:
        """Kill a worker that has sent nothing (not even a heartbeat) for heartbeat_timeout_s:
        stopped, deadlocked or stuck where no thread runs.  Its exit then replaces it."""
        period = min(self.settings.heartbeat_s, self.settings.heartbeat_timeout_s / 4)
        while not self._closing:
            await asyncio.sleep(period)
            for w in list(self._workers):
                if w.alive and w.hung(self.settings.heartbeat_timeout_s):
                    self.hung += 1
                    log.warning("worker hung (no heartbeat); killing it", extra={"fields": {
                        "worker": w.number, "pid": w.pid, "silent_s": round(w.silent_for(), 1)}})
                    w.ready = False
                    w.kill()

    def pids(self) -> list[int]:
        return [w.pid for w in self._workers if w.alive]

    def busy_pids(self) -> list[int]:
        return [w.pid for w in self._workers if w.alive and w.job is not None]

    # ---- messages from the reader threads (run on the loop) ----------------------------------

    def _on_message(self, w: _Worker, msg: tuple) -> None:
        kind = msg[0]
        if kind == "warming":  # what a worker's warm-up is doing (compiling kernels: minutes)
            w.warming = msg[2]
            log.info(msg[2], extra={"fields": {"worker": w.number, "pid": w.pid}})
            return
        if kind == "ready":
            w.ready = w.warmed = True
            w.warming = None
            self._failed_starts = 0
            log.info("worker ready", extra={"fields": {
                "worker": w.number, "pid": w.pid, "warmup_seconds": round(msg[2], 3),
                "gc_frozen": msg[3]}})
            if not self._warm and sum(x.ready for x in self._workers) >= self.size:
                self._warm = True
            self._free(w)
            return
        job = w.job
        if job is None or job.id != msg[1]:
            return  # a late message of a job that timed out or was abandoned
        job.messages.put_nowait(msg)
        if kind in _TERMINAL:
            self._finish(job)
            w.job = None
            w.jobs_done += 1
            if not self._closing:
                self._free(w)

    def _on_exit(self, w: _Worker, exitcode: int | None) -> None:
        was_ready = w.warmed
        w.alive = False
        w.ready = False
        if w in self._workers:
            self._workers.remove(w)
        job, w.job = w.job, None
        if job is not None and not job.finished:
            job.messages.put_nowait(("died", job.id, exitcode))
            self._finish(job)
        if w in self._idle:
            self._idle.remove(w)
        if self._closing:
            return
        log.warning("worker exited", extra={"fields": {
            "worker": w.number, "pid": w.pid, "exitcode": exitcode,
            "during_job": job is not None}})
        self.replaced += 1
        self._respawn_later(w, was_ready)

    def _respawn_later(self, w: _Worker, was_ready: bool) -> None:
        # A worker that dies before it was ever ready (broken install, engine import error) would
        # otherwise be restarted in a tight loop.
        delay = 0.0
        if not was_ready and w.jobs_done == 0 and time.monotonic() - w.started < 60.0:
            self._failed_starts += 1
            delay = min(_RESPAWN_BACKOFF_MAX_S, 0.5 * 2 ** (self._failed_starts - 1))
        if delay:
            self.loop.call_later(delay, self._respawn)
        else:
            self._respawn()  # at once: /health never sees the pool with a worker missing

    def _respawn(self) -> None:
        if not self._closing and len(self._workers) < self.size:
            self._spawn()

    # ---- jobs -------------------------------------------------------------------------------

    def _finish(self, job: _Job) -> None:
        if job.finished:
            return
        job.finished = True
        if job.timer is not None:
            job.timer.cancel()
            job.timer = None
        if job.on_finish is not None:
            job.on_finish()
        for f in job.cleanup:
            f()

    def _on_deadline(self, job: _Job, reason: str = "render past its time limit") -> None:
        w = job.worker
        if job.finished or w is None:
            return
        log.warning(f"{reason}; killing worker",
                    extra={"fields": {"worker": w.number, "pid": w.pid, "job": job.id}})
        job.messages.put_nowait(("timeout", job.id))
        self._finish(job)
        w.job = None  # its exit is then a plain replacement
        w.ready = False  # not ready from now, not from when its exit is seen
        w.kill()

    def _admit(self, heavy: bool = False) -> Callable[[], None]:
        """Take an admission slot (and a heavy one for a heavy render); returns its release."""
        if self._closing:
            raise PoolClosed("the server is shutting down")
        if self._in_flight >= self.capacity:
            raise PoolBusy(f"all {self.size} render workers are busy and the queue "
                           f"({self.settings.queue_size}) is full")
        if heavy and self._heavy_in_flight >= self.heavy_capacity:
            raise PoolBusy(
                f"this render is heavy (estimated over {self.settings.heavy_render_s:g} s) and "
                f"the {self.heavy_slots} worker(s) for heavy renders and their queue "
                f"({self.settings.heavy_queue_size}) are full; smaller renders are still served")
        self._in_flight += 1
        self._heavy_in_flight += heavy
        released = False

        def release() -> None:
            nonlocal released
            if not released:
                released = True
                self._in_flight -= 1
                self._heavy_in_flight -= heavy

        return release

    def _free(self, w: _Worker) -> None:
        """A worker has nothing to do: hand it to the waiting request of least rank, or keep it."""
        now = time.monotonic()
        while self._waiters:
            best = min(self._waiters, key=lambda x: x.rank(now))
            self._waiters.remove(best)
            if not best.future.done():  # not timed out or cancelled meanwhile
                best.future.set_result(w)
                return
        self._idle.append(w)

    async def _next_worker(self, deadline: float, cost: float) -> _Worker:
        if self._idle:
            return self._idle.pop(0)
        waiter = _Waiter(cost, time.monotonic(), self.loop.create_future())
        self._waiters.append(waiter)
        try:
            return await asyncio.wait_for(asyncio.shield(waiter.future),
                                          max(deadline - self.loop.time(), 0.0))
        except BaseException:
            if waiter in self._waiters:
                self._waiters.remove(waiter)
            if waiter.future.done() and not waiter.future.cancelled():
                self._free(waiter.future.result())  # handed over as we gave up: pass it on
            else:
                waiter.future.cancel()
            raise

    async def _acquire(self, deadline: float | None = None, cost: float = 0.0) -> _Worker:
        if deadline is None:
            deadline = self.loop.time() + self.settings.queue_timeout_s
        while True:
            try:
                w = await self._next_worker(deadline, cost)
            except TimeoutError:
                ready = sum(x.ready for x in self._workers)
                why = (f"; the workers are still starting ({ready} of {self.size} ready: they "
                       "compile or load the engine's kernels first, /health tells when)"
                       if ready < self.size and not self._warm else "")
                raise PoolBusy(f"no render worker became free within "
                               f"{self.settings.queue_timeout_s:g} s{why}") from None
            if self._responsive(w) and w.job is None:
                return w
            if w.alive and w.ready and w.job is None:  # silent for now: look again later
                self.loop.call_later(self.settings.heartbeat_s, self._requeue, w)

    def _requeue(self, w: _Worker) -> None:
        if w.alive and w.ready and w.job is None and not self._closing and w not in self._idle:
            self._free(w)

    async def _dispatch(self, kind: str, payload: dict[str, Any], time_limit_s: float,
                        on_finish: Callable[[], None] | None = None,
                        heavy: bool = False, wait_for_heavy: bool = False,
                        cost: float = 0.0) -> _Job:
        """Hand a job to an idle worker (the cheapest waiting first: ``cost`` is its estimated
        render seconds) and arm its deadline.  A heavy job first waits for one of the
        ``heavy_slots`` (fewer than the workers), so small renders always find one; a heavy
        render, a job of the runner and a heavy score render share those slots.  A job of the
        runner (``wait_for_heavy``) waits for its slot as long as it takes."""
        deadline = self.loop.time() + self.settings.queue_timeout_s
        if heavy:
            try:
                await asyncio.wait_for(self._heavy_running.acquire(),
                                       None if wait_for_heavy
                                       else max(deadline - self.loop.time(), 0.0))
            except TimeoutError:
                raise PoolBusy(f"no worker for heavy renders became free within "
                               f"{self.settings.queue_timeout_s:g} s") from None
        try:
            while True:
                w = await self._acquire(deadline, cost)
                job = _Job(next(self._job_ids), kind, on_finish=on_finish, heavy=heavy)
                if heavy:
                    job.cleanup.append(self._heavy_running.release)
                job.worker = w
                w.job = job
                try:
                    w.send((kind, job.id, payload))
                except OSError:
                    w.job = None  # died between being idle and now; its exit replaces it
                    job.cleanup.clear()
                    continue
                job.timer = self.loop.call_later(time_limit_s, self._on_deadline, job)
                return job
        except BaseException:
            if heavy:
                self._heavy_running.release()
            raise

    @staticmethod
    def _raise_for(msg: tuple, time_limit_s: float) -> None:
        kind = msg[0]
        if kind == "timeout":
            raise RenderTimeout(f"the render took longer than its time limit of "
                                f"{time_limit_s:.1f} s and was stopped")
        if kind == "died":
            raise WorkerDied(f"the render worker died during the render (exit code {msg[2]}); "
                             "it has been replaced")
        if kind == "error":
            raise RenderFailed(msg[2], msg[3])

    async def render(self, payload: dict[str, Any], time_limit_s: float,
                     heavy: bool = False, cost: float = 0.0) -> RenderOutput:
        """Render a whole scene in a worker; ``payload`` is what ``worker._render`` reads and
        ``cost`` its estimated seconds.  Cancelled (the client went away): a render still waiting
        costs nothing more; one running is stopped between two blocks (its worker then serves the
        next), or killed and replaced if it has not stopped ``_CANCEL_GRACE_S`` later."""
        release = self._admit(heavy)
        try:
            job = await self._dispatch("render", payload, time_limit_s, on_finish=release,
                                       heavy=heavy, cost=cost)
        except BaseException:
            release()
            raise
        try:
            msg = await job.messages.get()
        except asyncio.CancelledError:
            self._cancel(job, "render whose client left still running")
            raise
        self._raise_for(msg, time_limit_s)
        meta = msg[3]
        return RenderOutput(msg[2], meta["render_seconds"], meta["frames"], meta["energy_error"],
                            meta["warnings"])

    async def call(self, kind: str, payload: dict[str, Any], time_limit_s: float
                   ) -> tuple[bytes, dict[str, Any]]:
        """Run one job of another ``kind`` in a worker (``score``: import a score; ``labels``: a
        scene's labels) under the same admission and deadline as a render: a hostile file is
        handled by a worker that is killed at the deadline, never by the API process.  Returns
        the worker's bytes and meta.  It waits for a worker as a request of no cost (its cost is
        not known before it runs)."""
        release = self._admit()
        try:
            job = await self._dispatch(kind, payload, time_limit_s, on_finish=release)
        except BaseException:
            release()
            raise
        msg = await job.messages.get()
        self._raise_for(msg, time_limit_s)
        return msg[2], msg[3]

    async def stream(self, payload: dict[str, Any], time_limit_s: float,
                     heavy: bool = False, cost: float = 0.0) -> RenderStream:
        """Start a streamed render; returns once the first block exists (or fails before)."""
        release = self._admit(heavy)
        job: _Job | None = None
        try:
            job = await self._dispatch("stream", payload, time_limit_s, heavy=heavy, cost=cost)
            first = await job.messages.get()
            self._raise_for(first, time_limit_s)
        except BaseException:
            if job is not None:
                self._cancel(job)  # e.g. the client left before the first block
            release()
            raise
        return RenderStream(self, job, first, time_limit_s, release)

    def _cancel(self, job: _Job, reason: str = "cancelled stream still running") -> None:
        w = job.worker
        if job.finished or w is None or w.job is not job:
            return
        try:
            w.send(("cancel", job.id))
        except OSError:
            return
        # A worker stuck inside one long block would ignore the cancel until the block is done.
        self.loop.call_later(_CANCEL_GRACE_S, self._on_deadline, job, reason)

    # ---- jobs of service.jobs ---------------------------------------------------------------

    async def job_stream(self, payload: dict[str, Any], time_limit_s: float,
                         cost: float = 0.0) -> RenderStream:
        """A streamed render for the job runner (``service.jobs``), whose blocks it writes to a
        file.  It takes no admission slot of ``/render``: the runner keeps its own queue (in
        SQLite) and bounds how many jobs run at once.  Every job, whatever its estimate
        (``cost``), takes one of the heavy slots that heavy renders use too: jobs and heavy
        renders together never hold every worker, and a worker stays for interactive requests.
        It waits for a slot and a worker as long as it takes (with the other requests waiting
        for a worker, by ``cost`` less the seconds waited; heavy slots are first come, first
        served)."""
        job: _Job | None = None
        try:
            while True:
                if self._closing:
                    raise PoolClosed("the server is shutting down")
                try:
                    job = await self._dispatch("stream", payload, time_limit_s, heavy=True,
                                               wait_for_heavy=True, cost=cost)
                    break
                except PoolBusy:
                    continue  # no worker free within queue_timeout_s: keep waiting
            first = await job.messages.get()
            self._raise_for(first, time_limit_s)
        except BaseException:
            if job is not None:
                self._cancel(job)
            raise
        # it holds no admission slot: closing it only stops the render
        return RenderStream(self, job, first, time_limit_s, release=lambda: None)


class RenderStream:
    """A streamed render in progress: the first block, then the rest as the worker sends it."""

    def __init__(self, pool: WorkerPool, job: _Job, first: tuple, time_limit_s: float,
                 release: Callable[[], None]):
        self._pool = pool
        self._release = release
        self._job = job
        self._first = first
        self._time_limit_s = time_limit_s
        self._closed = False
        self.render_seconds = first[3] if first[0] == "block" else first[2]["render_seconds"]
        self.first_block_seconds = self.render_seconds
        # the engine's warnings come with the first block (or the end of a stream of none)
        self.warnings: list[str] = first[4] if first[0] == "block" else first[2]["warnings"]
        self.scale: float | None = None  # the samples per m/s, told at the end

    async def chunks(self) -> AsyncIterator[bytes]:
        msg = self._first
        while True:
            kind = msg[0]
            if kind == "block":
                self.render_seconds = msg[3]
                yield msg[2]
            elif kind == "end":
                self.render_seconds = msg[2]["render_seconds"]
                self.scale = msg[2].get("scale")
                return
            else:
                try:
                    self._pool._raise_for(msg, self._time_limit_s)
                except PoolError as exc:
                    raise StreamAborted(str(exc)) from exc
                raise StreamAborted(f"unexpected message {kind!r}")
            msg = await self._job.messages.get()

    def close(self) -> None:
        """Stop the render if it still runs (client gone) and free the admission slot."""
        if self._closed:
            return
        self._closed = True
        self._pool._cancel(self._job)
        self._release()
