"""The ASGI application: wiring only (settings, logging, middleware, pool lifespan, routers).

    uvicorn service.app:app

Handlers live in ``service.routes``; the worker pool in ``service.pool``; settings in
``service.config`` (``GUITAR_*`` environment variables).
"""

from __future__ import annotations

import asyncio
import gc
from collections.abc import AsyncIterator
from contextlib import asynccontextmanager

from fastapi import FastAPI
from fastapi.staticfiles import StaticFiles

from . import errors, heap, jobs
from .config import Settings
from .live import LivePool, relay_in_real_time
from .logs import setup_logging
from .metrics import Metrics, MetricsMiddleware
from .middleware import BodyLimitMiddleware, RequestContextMiddleware
from .pool import WorkerPool
from .routes import health, live, metrics, pages, presets, render, score
from .score_cache import ScoreCache

DESCRIPTION = """Physically modelled guitar synthesis over HTTP: send a scene (a guitar preset and
timed events: pluck, fret, tap and the articulations hammer-on, pull-off, slide, bend, vibrato,
harmonic, mute and strum), get audio back. The scene schema is the engine's own
(`engine.Scene`); this server adds limits on body size, duration, events and sample rate
(see `GET /limits`), a pool of render worker processes and streaming."""


def create_app(settings: Settings | None = None) -> FastAPI:
    settings = settings or Settings()
    setup_logging(settings.log_level)

    counters = Metrics()

    @asynccontextmanager
    async def lifespan(app: FastAPI) -> AsyncIterator[dict]:
        # Bodies of every size pass through this process; mapped on their own, the large ones go
        # back to the system when freed instead of leaving holes in the heap (service/heap.py).
        mapped = settings.api_mmap_threshold_kib * 1024
        if mapped and not heap.map_large_blocks(mapped):
            mapped = 0
        pool = WorkerPool(settings)
        await pool.start()  # workers warm up in the background; /health tells when they are
        live_pool = LivePool(settings)  # WS /live: processes of their own (service/live.py)
        await live_pool.start()
        relay_in_real_time(settings.relay_realtime_priority)
        store = jobs.Store(settings.data_dir)
        runner = jobs.JobRunner(store, pool, settings)
        await runner.start()  # jobs a crash cut off are queued again
        scores = ScoreCache(int(settings.score_cache_mb * 1e6))

        def state() -> dict:
            s = pool.status()
            # renders admitted but not yet on a worker (job streams hold workers, not slots)
            waiting = max(0, s["in_flight"] - (s["busy"] - runner.running))
            return {**s, "queue_depth": waiting, "jobs": store.counts(),
                    "jobs_requeued": runner.completed["requeued"],
                    "live_late_blocks": live_pool.late_blocks,
                    "score_cache": {"hit": scores.hits, "miss": scores.misses},
                    "heap_mmap_threshold": mapped}

        counters.watch(state)
        loop_watch = asyncio.create_task(counters.watch_loop(), name="loop-lag")
        gc_unwatch = counters.watch_gc()
        # What exists now (modules, routes, schemas, settings) lives as long as the process: out
        # of the collector's sight, a full collection no longer walks it: each collection stops
        # the event loop, which relays live blocks within a jitter budget of tens of ms
        # (guitar_gc_pause_seconds; benchmarks/mixed_load.py prints them).
        gc.freeze()
        try:
            yield {"pool": pool, "settings": settings, "live": live_pool, "jobs": runner,
                   "metrics": counters, "scores": scores}
        finally:
            loop_watch.cancel()
            gc_unwatch()
            # Uvicorn has let the requests in flight finish; running jobs go back to the queue
            # before the workers stop, so that the next start runs them again.
            await runner.stop()
            await live_pool.close()
            await pool.close()
            store.close()

    # /docs and /redoc are served from local assets (service/routes/pages.py), not FastAPI's CDN
    app = FastAPI(title="Guitar synthesis service", version="1.0.0", description=DESCRIPTION,
                  lifespan=lifespan, docs_url=None, redoc_url=None,
                  swagger_ui_oauth2_redirect_url="/docs/oauth2-redirect")
    # Added innermost first: the request-id/access-log layer also sees 413s.
    app.add_middleware(BodyLimitMiddleware, max_bytes=settings.max_body_bytes)
    app.add_middleware(MetricsMiddleware, metrics=counters)
    app.add_middleware(RequestContextMiddleware)
    errors.install(app, settings.retry_after_s)
    jobs.install(app)
    for router in (pages.router, pages.docs_router, health.router, presets.router, render.router,
                   score.router, score.labels_router, live.router, jobs.router, metrics.router):
        app.include_router(router)
    app.mount("/static", StaticFiles(directory=pages.STATIC_DIR), name="static")
    app.mount(pages.DOCS_ASSETS, pages.docs_assets(), name="docs-assets")
    return app


app = create_app()
