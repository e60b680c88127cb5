"""Fixtures of the service tests: the app in-process (httpx over ASGI, lifespan run explicitly)
and as a real uvicorn process on 127.0.0.1.

Worker processes are expensive to start (numba kernels load from the on-disk cache, or compile on
a cold cache), so one app per configuration is shared by a whole session.  Every process started
here inherits this environment, so ``NUMBA_CACHE_DIR`` (if set) is the same for all of them.
"""

from __future__ import annotations

import asyncio
import os
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Coroutine, Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest

ROOT = Path(__file__).resolve().parents[2]
if str(ROOT) not in sys.path:  # `pytest` run without PYTHONPATH=. from the repo root
    sys.path.insert(0, str(ROOT))

from service.app import create_app  # noqa: E402
from service.config import Settings  # noqa: E402

# Cold numba caches compile for ~15 s per process; allow for two compiling side by side.
STARTUP_TIMEOUT_S = 120.0


class AppHarness:
    """Runs an ASGI app and its lifespan on an event loop in a background thread.

    Tests stay synchronous: ``request`` sends one request through ``httpx.ASGITransport``,
    ``run`` runs any coroutine (e.g. several requests at once) on the app's loop.
    """

    def __init__(self, settings: Settings):
        self.app = create_app(settings)
        self.settings = settings
        self.loop = asyncio.new_event_loop()
        self.thread = threading.Thread(target=self.loop.run_forever, name="app-loop", daemon=True)
        self.state: dict[str, Any] = {}
        self._lifespan_in: asyncio.Queue | None = None
        self._lifespan_task: asyncio.Task | None = None
        self.client: httpx.AsyncClient | None = None

    def run(self, coro: Coroutine, timeout: float = 60.0) -> Any:
        return asyncio.run_coroutine_threadsafe(coro, self.loop).result(timeout)

    def request(self, method: str, url: str, timeout: float = 60.0, **kwargs: Any) -> httpx.Response:
        assert self.client is not None
        return self.run(self.client.request(method, url, **kwargs), timeout)

    def get(self, url: str, **kwargs: Any) -> httpx.Response:
        return self.request("GET", url, **kwargs)

    def post(self, url: str, **kwargs: Any) -> httpx.Response:
        return self.request("POST", url, **kwargs)

    @property
    def pool(self) -> Any:
        return self.state["pool"]

    # The ASGI lifespan protocol, as a server speaks it: startup, then (later) shutdown.
    async def _startup(self) -> None:
        self._lifespan_in = asyncio.Queue()
        started: asyncio.Future = self.loop.create_future()

        async def receive() -> dict:
            assert self._lifespan_in is not None
            return await self._lifespan_in.get()

        async def send(message: dict) -> None:
            if message["type"] == "lifespan.startup.complete":
                started.set_result(None)
            elif message["type"] == "lifespan.startup.failed":
                started.set_exception(RuntimeError(message.get("message", "startup failed")))

        scope = {"type": "lifespan", "asgi": {"version": "3.0", "spec_version": "2.0"},
                 "state": self.state}
        self._lifespan_task = asyncio.create_task(self.app(scope, receive, send))
        await self._lifespan_in.put({"type": "lifespan.startup"})
        await started
        transport = httpx.ASGITransport(app=self._with_state, client=("127.0.0.1", 50000))
        self.client = httpx.AsyncClient(transport=transport, base_url="http://testserver")

    async def _with_state(self, scope: dict, receive: Any, send: Any) -> None:
        # A server gives each request a shallow copy of the lifespan state.
        scope["state"] = dict(self.state)
        await self.app(scope, receive, send)

    async def _shutdown(self) -> None:
        if self.client is not None:
            await self.client.aclose()
        assert self._lifespan_in is not None and self._lifespan_task is not None
        await self._lifespan_in.put({"type": "lifespan.shutdown"})
        await asyncio.wait_for(self._lifespan_task, 30.0)

    def start(self) -> AppHarness:
        self.thread.start()
        self.run(self._startup())
        wait_ready(lambda: self.get("/health").status_code == 200)
        return self

    def stop(self) -> None:
        try:
            self.run(self._shutdown(), timeout=40.0)
        finally:
            self.loop.call_soon_threadsafe(self.loop.stop)
            self.thread.join(10.0)


def wait_ready(check: Any, timeout: float = STARTUP_TIMEOUT_S) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        try:
            if check():
                return
        except (httpx.TransportError, OSError):
            pass
        time.sleep(0.1)
    raise TimeoutError(f"not ready within {timeout} s")


@pytest.fixture(scope="session")
def harness(tmp_path_factory: pytest.TempPathFactory) -> Iterator[AppHarness]:
    """The app with two workers and default limits; its jobs in a folder of its own (the default
    ``./data`` would resume whatever jobs an earlier run left there)."""
    data = tmp_path_factory.mktemp("harness-data")
    h = AppHarness(Settings(workers=2, queue_size=8, data_dir=str(data))).start()
    yield h
    h.stop()


@pytest.fixture(scope="session")
def tiny_harness(tmp_path_factory: pytest.TempPathFactory) -> Iterator[AppHarness]:
    """One worker, no queue and a short time limit: for 503 and 504 (a budget far above the
    default, so that a render can be sent that outlasts the time limit)."""
    settings = Settings(workers=1, queue_size=0, time_limit_base_s=0.5, time_limit_per_audio_s=0.0,
                        queue_timeout_s=5.0, retry_after_s=3, stream_block_frames=1 << 20,
                        max_render_s=1000.0, data_dir=str(tmp_path_factory.mktemp("tiny-data")))
    h = AppHarness(settings).start()
    yield h
    h.stop()


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class UvicornServer:
    """``uvicorn service.app:app`` in a subprocess on 127.0.0.1; stopped by its PID."""

    def __init__(self, tmp: Path, env: dict[str, str] | None = None):
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.log_path = tmp / f"uvicorn-{self.port}.log"
        # jobs in the test's folder unless the test names one: the default ./data would resume
        # the jobs an earlier run left there
        self.env = {**os.environ, "PYTHONPATH": os.pathsep.join(
            p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p),
            "GUITAR_DATA_DIR": str(tmp / "data"), **(env or {})}
        self.proc: subprocess.Popen | None = None

    def start(self) -> UvicornServer:
        self._log = open(self.log_path, "wb")  # noqa: SIM115 - closed in stop()
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "uvicorn", "service.app:app", "--host", "127.0.0.1",
             "--port", str(self.port), "--no-access-log"],
            cwd=ROOT, env=self.env, stdout=self._log, stderr=subprocess.STDOUT,
        )

        def healthy() -> bool:
            assert self.proc is not None
            if self.proc.poll() is not None:
                raise RuntimeError(f"uvicorn exited: {self.log_path.read_text()[-2000:]}")
            return httpx.get(self.url + "/health", timeout=2.0).status_code == 200

        wait_ready(healthy)
        return self

    def log_lines(self) -> list[str]:
        return self.log_path.read_text(errors="replace").splitlines()

    def stop(self) -> None:
        if self.proc is None:
            return
        if self.proc.poll() is None:
            os.kill(self.proc.pid, signal.SIGTERM)  # graceful: the lifespan stops the workers
            try:
                self.proc.wait(20.0)
            except subprocess.TimeoutExpired:
                os.kill(self.proc.pid, signal.SIGKILL)
                self.proc.wait(5.0)
        self._log.close()


@pytest.fixture(scope="session")
def server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[UvicornServer]:
    s = UvicornServer(tmp_path_factory.mktemp("uvicorn"), {"GUITAR_WORKERS": "2"}).start()
    yield s
    s.stop()
