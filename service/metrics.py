"""GET /metrics: the service's counters in Prometheus' text format (``prometheus_client``).

Counted as requests end (``MetricsMiddleware``): requests by route and status, renders by endpoint
and outcome, render wall time and audio seconds.  Measured all along (``Metrics.watch_loop``): the
event loop's lag.  Measured as they happen: the pauses of Python's garbage collector
(``Metrics.watch_gc``), each a stall of the event loop, and each live block's relay through this
process.  Read when scraped (``_StateCollector``): jobs by status, the pool's queue depth, busy and
ready workers, worker restarts.  Each app has a registry of its own, so several apps in one
process (tests) do not share counters.
"""

from __future__ import annotations

import asyncio
import gc
import logging
import re
import time
from collections.abc import Callable, Iterator
from typing import Any

from prometheus_client import CONTENT_TYPE_LATEST, CollectorRegistry, Counter, Histogram
from prometheus_client import generate_latest as _generate
from prometheus_client.core import CounterMetricFamily, GaugeMetricFamily
from prometheus_client.registry import Collector
from starlette.types import ASGIApp, Message, Receive, Scope, Send

log = logging.getLogger("service.metrics")

LOOP_PROBE_S = 0.1  # the event loop's lag is measured this often (``Metrics.watch_loop``)
RENDER_PATHS = frozenset({"/render", "/render/stream", "/render/score"})
_KNOWN = frozenset({"/", "/health", "/limits", "/presets", "/metrics", "/jobs", "/docs",
                    "/openapi.json", *RENDER_PATHS})
_JOB_PATH = re.compile(r"^/jobs/[^/]+(/audio|/stream|/labels|/stems)?$")


def route_label(path: str) -> str:
    """A bounded set of labels: job ids and unknown paths are not labels of their own."""
    if path in _KNOWN:
        return path
    m = _JOB_PATH.match(path)
    if m:
        return "/jobs/{id}" + (m.group(1) or "")
    if path.startswith("/static/"):
        return "/static"
    return "other"


class Metrics:
    def __init__(self) -> None:
        self.registry = CollectorRegistry()
        self.requests = Counter("guitar_http_requests", "HTTP requests answered",
                                ["route", "method", "status"], registry=self.registry)
        self.renders = Counter("guitar_renders", "renders by endpoint and outcome (ok: 2xx)",
                               ["endpoint", "outcome"], registry=self.registry)
        self.render_seconds = Histogram(
            "guitar_render_seconds", "wall time of successful renders, s", ["endpoint"],
            buckets=(0.01, 0.03, 0.1, 0.3, 1.0, 3.0, 10.0, 30.0, 100.0, 300.0),
            registry=self.registry)
        self.audio_seconds = Counter("guitar_audio_seconds", "seconds of audio rendered",
                                     ["endpoint"], registry=self.registry)
        self.loop_lag = Histogram(
            "guitar_event_loop_lag_seconds", "how late the API process's event loop ran a "
            f"callback due every {LOOP_PROBE_S:g} s (what every request and live block waited "
            "on top of its own work)",
            buckets=(0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1.0, 2.5, 5.0, 10.0, 30.0),
            registry=self.registry)
        self.live_relay = Histogram(
            "guitar_live_relay_seconds", "from a live block's sending by its live worker to its "
            "hand-over to the client's WebSocket (the pipe, the API process's wake-up and "
            "event loop, the send)",
            buckets=(0.001, 0.0025, 0.005, 0.01, 0.02, 0.04, 0.1, 0.25, 1.0),
            registry=self.registry)
        self.gc_pause = Histogram(
            "guitar_gc_pause_seconds", "pauses of the API process's garbage collector by "
            "generation (the event loop stands still for each)", ["generation"],
            buckets=(0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 1.0),
            registry=self.registry)

    def watch_gc(self) -> Callable[[], None]:
        """Time every collection of the garbage collector from now on; returns the function that
        stops it."""
        started = [0.0]

        def callback(phase: str, info: dict[str, int]) -> None:
            if phase == "start":
                started[0] = time.perf_counter()
            else:
                self.gc_pause.labels(str(info["generation"])).observe(
                    time.perf_counter() - started[0])

        gc.callbacks.append(callback)
        return lambda: gc.callbacks.remove(callback)

    async def watch_loop(self) -> None:
        """Measure the event loop's lag for as long as the app runs: a callback due every
        ``LOOP_PROBE_S``, how late it ran.  A lag over a second is logged as a warning."""
        loop = asyncio.get_running_loop()
        while True:
            due = loop.time() + LOOP_PROBE_S
            await asyncio.sleep(LOOP_PROBE_S)
            lag = max(0.0, loop.time() - due)
            self.loop_lag.observe(lag)
            if lag > 1.0:
                log.warning("event loop stalled", extra={"fields": {"lag_s": round(lag, 3)}})

    def watch(self, state: Callable[[], dict[str, Any]]) -> None:
        """Report ``state()`` (the pool's and the job store's figures) at every scrape."""
        self.registry.register(_StateCollector(state))

    def observe(self, route: str, method: str, status: int, info: dict[str, Any]) -> None:
        self.requests.labels(route, method, str(status)).inc()
        if route in RENDER_PATHS and method == "POST":
            ok = 200 <= status < 300 and not info.get("error")
            self.renders.labels(route, "ok" if ok else str(status)).inc()
            if ok and info.get("render_seconds") is not None:
                self.render_seconds.labels(route).observe(info["render_seconds"])
            if ok and info.get("audio_seconds") is not None:
                self.audio_seconds.labels(route).inc(info["audio_seconds"])

    def exposition(self) -> tuple[bytes, str]:
        return _generate(self.registry), CONTENT_TYPE_LATEST


class _StateCollector(Collector):
    def __init__(self, state: Callable[[], dict[str, Any]]):
        self.state = state

    def collect(self) -> Iterator[Any]:
        s = self.state()
        if not s:
            return
        jobs = GaugeMetricFamily("guitar_jobs", "jobs stored, by status", labels=["status"])
        for status, n in s["jobs"].items():
            jobs.add_metric([status], n)
        yield jobs
        yield GaugeMetricFamily("guitar_queue_depth", "renders admitted and waiting for a worker "
                                "(/render and /render/stream)", value=s["queue_depth"])
        yield GaugeMetricFamily("guitar_jobs_queue_depth", "jobs waiting for the job runner",
                                value=s["jobs"].get("queued", 0))
        yield GaugeMetricFamily("guitar_workers", "render worker processes configured",
                                value=s["workers"])
        yield GaugeMetricFamily("guitar_workers_ready", "workers warmed up and alive",
                                value=s["workers_ready"])
        yield GaugeMetricFamily("guitar_workers_busy", "workers rendering now", value=s["busy"])
        yield CounterMetricFamily("guitar_worker_restarts", "workers replaced since start "
                                  "(killed at a time limit, crashed)", value=s["replaced"])
        yield CounterMetricFamily("guitar_jobs_requeued", "job runs cut off by a dead worker "
                                  "and queued again", value=s["jobs_requeued"])
        yield CounterMetricFamily("guitar_live_late_blocks", "live blocks finished after their "
                                  "play time (underruns the server caused)",
                                  value=s["live_late_blocks"])
        yield GaugeMetricFamily("guitar_heap_mmap_threshold_bytes", "blocks of at least this "
                                "size the API process's C heap maps on their own and returns "
                                "when freed (GUITAR_API_MMAP_THRESHOLD_KIB); 0: the C library's "
                                "default", value=s["heap_mmap_threshold"])
        imports = CounterMetricFamily("guitar_score_imports", "score imports asked for, by "
                                      "whether an earlier import answered (hit) or a worker "
                                      "imported the file (miss)", labels=["cache"])
        for outcome, n in s["score_cache"].items():
            imports.add_metric([outcome], n)
        yield imports


class MetricsMiddleware:
    """Counts every HTTP request when its response has been sent (a stream: its last byte)."""

    def __init__(self, app: ASGIApp, metrics: Metrics):
        self.app = app
        self.metrics = metrics

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        status = {"code": 500}

        async def send_wrapper(message: Message) -> None:
            if message["type"] == "http.response.start":
                status["code"] = message["status"]
            await send(message)

        error = False
        try:
            await self.app(scope, receive, send_wrapper)
        except BaseException:
            error = True
            raise
        finally:
            state = scope.get("state") or {}
            self.metrics.observe(route_label(scope.get("path", "")), scope.get("method", ""),
                                 status["code"], {"render_seconds": state.get("render_seconds"),
                                                  "audio_seconds": state.get("audio_seconds"),
                                                  "error": error})
