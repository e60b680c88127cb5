"""A worker process on a duplex pipe, with a thread that hands everything it sends to the event
loop: what the render pool (``service.pool``) and the live-session pool (``service.live``) share.

The thread blocks on the pipe and passes each message to ``pool._on_message(worker, msg)`` on the
loop (``call_soon_threadsafe``); the process's death shows up as end-of-file on the pipe, whatever
killed it, and reaches ``pool._on_exit(worker, exitcode)``.  All pool state is touched on the
loop only.  Processes are spawned or forkserved, never forked (the parent runs threads and an
event loop), and are daemons, so they never outlive the server.
"""

from __future__ import annotations

import asyncio
import threading
import time
from collections.abc import Callable
from typing import Any


class PipedProcess:
    """One worker process, its pipe and the thread that reads the pipe."""

    def __init__(self, pool: Any, ctx: Any, number: int, target: Callable[..., None],
                 args: tuple, name: str):
        self.pool = pool
        self.number = number
        parent_conn, child_conn = ctx.Pipe(duplex=True)
        self.proc = ctx.Process(target=target, args=(child_conn, *args), name=name, daemon=True)
        self.proc.start()
        child_conn.close()  # so that the worker's death closes the pipe for the reader
        self.conn = parent_conn
        self.started = time.monotonic()
        self.ready = False
        self.alive = True
        self._send_lock = threading.Lock()  # the loop and a session's threads may both send
        self.thread = threading.Thread(target=self._read, name=f"{name}-reader", daemon=True)
        self.thread.start()

    @property
    def pid(self) -> int:
        return self.proc.pid or 0

    def received(self, msg: Any) -> bool:
        """Called on the reader thread for every message; False keeps it from the loop."""
        return True

    def _read(self) -> None:
        loop = self.pool.loop
        while True:
            try:
                msg = self.conn.recv()
            except (EOFError, OSError):
                break
            if not self.received(msg):
                continue
            try:
                loop.call_soon_threadsafe(self.pool._on_message, self, msg)
            except RuntimeError:  # the loop is closed: the server is gone
                return
        self.proc.join()
        try:
            loop.call_soon_threadsafe(self.pool._on_exit, self, self.proc.exitcode)
        except RuntimeError:
            pass

    def send(self, msg: Any) -> None:
        with self._send_lock:
            self.conn.send(msg)

    def kill(self) -> None:
        if self.proc.is_alive():
            self.proc.kill()  # SIGKILL: also ends a stopped (SIGSTOP) process


async def stop_all(workers: list[PipedProcess], timeout_s: float) -> None:
    """Ask every worker to exit (``None`` on its pipe), give them ``timeout_s`` together, kill the
    ones still running and close their pipes; ``workers`` is emptied."""
    for w in workers:
        try:
            w.send(None)
        except OSError:
            pass
    deadline = time.monotonic() + timeout_s
    for w in list(workers):
        await asyncio.to_thread(w.proc.join, max(0.0, deadline - time.monotonic()))
        w.kill()
        await asyncio.to_thread(w.proc.join, 1.0)
        w.conn.close()
    workers.clear()
