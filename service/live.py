"""Live sessions (``WS /live``) run in a small pool of processes of their own.

Why not the render workers: a render holds its worker for seconds, and a live session must get its
next block within milliseconds, every few milliseconds, for as long as it is played.  Sharing would
let one stall the other either way.  So ``GUITAR_LIVE_WORKERS`` processes (default 1) each host
several sessions (``service.live_worker``), and the render workers stay as they are.  Sessions go
to the least loaded live worker; at most ``GUITAR_MAX_LIVE_SESSIONS`` are open at once (more are
refused: ``LiveBusy``).  The live workers start with the first session (which waits for them to warm
up), not with the server: a server that only renders never pays for them (a warm worker holds the
engine's compiled kernels, hundreds of MB), and their warm-up does not take CPU from the render
workers' start.  ``GUITAR_LIVE_PRESTART`` starts them with the server instead.  A live worker that
dies ends its sessions (their sockets are closed with 1011) and is replaced, as a render worker is.

Threads and the loop, as in ``service.pool``: a reader thread per worker hands every message to the
event loop; all state here is touched on the loop only.
"""

from __future__ import annotations

import asyncio
import itertools
import logging
import multiprocessing as mp
import os
from dataclasses import dataclass, field
from typing import Any

from . import live_worker
from .config import Settings
from .processes import PipedProcess, stop_all

log = logging.getLogger("service.live")


def relay_in_real_time(priority: int) -> None:
    """The calling thread (the API's event loop, which relays every live block from its worker's
    pipe to its socket, and each live worker's pipe reader) on SCHED_RR at ``priority``: a block
    that arrives is sent at once rather than after the renders and clients that share the cores
    (the relay's tail under load was its thread waiting to run, not busy).
    ``SCHED_RESET_ON_FORK``: threads and processes started from it later (render workers, file
    threads) get normal scheduling."""
    if not priority:
        return
    try:
        os.sched_setscheduler(0, os.SCHED_RR | os.SCHED_RESET_ON_FORK, os.sched_param(priority))
    except (OSError, AttributeError) as exc:
        log.warning("relay real-time priority %d not set (%s); normal scheduling", priority, exc)


class LiveBusy(Exception):
    pass


class LiveUnavailable(Exception):
    pass


@dataclass
class LiveSession:
    id: int
    worker: _LiveWorker
    messages: asyncio.Queue = field(default_factory=asyncio.Queue)
    closed: bool = False


class _LiveWorker(PipedProcess):
    """A live worker: the sessions open on it."""

    def __init__(self, pool: LivePool, ctx: Any, number: int):
        self.sessions: dict[int, LiveSession] = {}
        s = pool.settings
        super().__init__(pool, ctx, number, live_worker.main,
                         (s.warmup, s.live_lead_ms / 1000.0, s.live_nice,
                          s.live_realtime_priority),
                         f"live-worker-{number}")

    def _read(self) -> None:
        # This thread takes every block off the worker's pipe and hands it to the event loop: on
        # the loop thread's real-time priority too, or under load a block waits here for a core.
        relay_in_real_time(self.pool.settings.relay_realtime_priority)
        super()._read()


class LivePool:
    """The live-session worker processes and the sessions open on them."""

    def __init__(self, settings: Settings):
        self.settings = settings
        self.size = settings.live_workers
        self.limit = settings.max_live_sessions
        self.loop: asyncio.AbstractEventLoop
        self._ctx = mp.get_context(settings.mp_context)
        self._workers: list[_LiveWorker] = []
        self._numbers = itertools.count(1)
        self._ids = itertools.count(1)
        self._closing = False
        self._started = False
        self._opening = 0  # sessions waiting for a live worker to warm up
        self._ready_event: asyncio.Event
        self.replaced = 0
        self.late_blocks = 0  # blocks a live worker finished after their play time

    async def start(self) -> None:
        self.loop = asyncio.get_running_loop()
        self._ready_event = asyncio.Event()
        if self.settings.live_prestart:
            self._start_workers()

    def _start_workers(self) -> None:
        if not self._started:
            self._started = True
            for _ in range(self.size):
                self._spawn()

    def _spawn(self) -> None:
        w = _LiveWorker(self, self._ctx, next(self._numbers))
        self._workers.append(w)
        log.info("live worker started", extra={"fields": {"worker": w.number, "pid": w.pid}})

    async def close(self, timeout_s: float = 5.0) -> None:
        self._closing = True
        await stop_all(self._workers, timeout_s)

    @property
    def ready(self) -> bool:
        return any(w.ready for w in self._workers)

    @property
    def open_sessions(self) -> int:
        return sum(len(w.sessions) for w in self._workers)

    def status(self) -> dict[str, Any]:
        return {"live_workers": self.size, "started": self._started,
                "live_workers_ready": sum(w.ready for w in self._workers),
                "live_sessions": self.open_sessions, "max_live_sessions": self.limit,
                "late_blocks": self.late_blocks}

    def pids(self) -> list[int]:
        return [w.pid for w in self._workers if w.alive]

    # ---- sessions ---------------------------------------------------------------------------

    async def open(self, message: dict) -> LiveSession:
        """Start a session on the least loaded ready worker (the open message was validated),
        starting the live workers first if they are not yet, and waiting for one to be ready;
        its first message (``opened`` or ``failed``) arrives on ``session.messages``."""
        if self._closing:
            raise LiveUnavailable("the server is shutting down")
        if self.size == 0:
            raise LiveUnavailable("live play is off on this server (GUITAR_LIVE_WORKERS=0)")
        if self.open_sessions + self._opening >= self.limit:
            raise LiveBusy(f"too many live sessions: the limit is {self.limit}")
        self._start_workers()
        self._opening += 1
        try:
            await asyncio.wait_for(self._ready_event.wait(),
                                   self.settings.live_start_timeout_s)
        except TimeoutError:
            raise LiveUnavailable("no live worker became ready in time") from None
        finally:
            self._opening -= 1
        ready = [w for w in self._workers if w.ready and w.alive]
        if not ready or self._closing:
            raise LiveUnavailable("no live worker is ready; try again")
        w = min(ready, key=lambda x: len(x.sessions))
        s = LiveSession(next(self._ids), w)
        w.sessions[s.id] = s
        try:
            w.send(("open", s.id, message))
        except OSError as exc:
            w.sessions.pop(s.id, None)
            raise LiveUnavailable("the live worker is gone; try again") from exc
        return s

    def event(self, s: LiveSession, message: dict) -> None:
        if not s.closed:
            try:
                s.worker.send(("event", s.id, message))
            except OSError:
                pass  # its exit ends the session

    def end(self, s: LiveSession) -> None:
        if s.closed:
            return
        s.closed = True
        s.worker.sessions.pop(s.id, None)
        try:
            s.worker.send(("close", s.id))
        except OSError:
            pass

    # ---- messages from the reader threads ----------------------------------------------------

    def _on_message(self, w: _LiveWorker, msg: tuple) -> None:
        """A message of a live worker; a block carries the time its worker sent it (last), by
        which its relay is timed."""
        if msg[0] == "ready":
            w.ready = True
            self._ready_event.set()
            log.info("live worker ready", extra={"fields": {
                "worker": w.number, "pid": w.pid, "warmup_seconds": round(msg[2], 3),
                "gc_frozen": msg[3]}})
            return
        if msg[0] == "late":
            self.late_blocks += msg[2]
            return
        s = w.sessions.get(msg[1])
        if s is not None:
            s.messages.put_nowait(msg)
            if msg[0] == "failed":
                s.closed = True
                w.sessions.pop(s.id, None)

    def _on_exit(self, w: _LiveWorker, exitcode: int | None) -> None:
        w.alive = False
        w.ready = False
        if w in self._workers:
            self._workers.remove(w)
        if not any(x.ready for x in self._workers):
            self._ready_event.clear()
        for s in list(w.sessions.values()):
            s.closed = True
            s.messages.put_nowait(("died", s.id, exitcode))
        w.sessions.clear()
        if self._closing:
            return
        log.warning("live worker exited", extra={"fields": {
            "worker": w.number, "pid": w.pid, "exitcode": exitcode}})
        self.replaced += 1
        self.loop.call_later(1.0, self._respawn)

    def _respawn(self) -> None:
        if not self._closing and len(self._workers) < self.size:
            self._spawn()
