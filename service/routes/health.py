"""Liveness and readiness of the service, and the limits this server puts on a scene.

* ``GET /health/live``: 200 while the process answers requests (its event loop runs); a container
  orchestrator restarts the server when this fails.
* ``GET /health/ready``: 200 when a render worker can take a render now (warmed up, alive and
  heard from within the last heartbeats); 503 otherwise: a load balancer sends no traffic.
* ``GET /health``: 200 once every worker has warmed up, and from then on while some worker process
  is alive (ready, or a replacement warming up: the pool replaces dead and hung workers by
  itself, so a replacement in progress is no reason to restart the server); 503 before the first
  warm-up, or when no worker process is alive at all.
"""

from __future__ import annotations

from fastapi import APIRouter, Request
from fastapi.responses import JSONResponse

from ..schemas import Health, Limits, PoolStatus

router = APIRouter(tags=["service"])


def _status(pool) -> str:
    if pool.ready:
        return "ok"
    return "degraded" if pool.healthy else "starting"


@router.get("/health", response_model=Health,
            responses={503: {"model": Health, "description": "workers still warming up, or none "
                                                            "alive"}})
async def health(request: Request) -> JSONResponse:
    """200 once every render worker has warmed up (compiled or loaded its kernels), and from then
    on while some worker process is alive, ready or being replaced (``status`` 'ok' or
    'degraded'); else 503 ('starting')."""
    pool = request.state.pool
    healthy = pool.healthy
    body = Health(status=_status(pool), ready=pool.ready, pool=PoolStatus(**pool.status()))
    return JSONResponse(body.model_dump(), status_code=200 if healthy else 503)


@router.get("/health/live")
async def live() -> dict[str, str]:
    """200 while the server process answers: for a liveness probe (restart when it fails)."""
    return {"status": "alive"}


@router.get("/health/ready", response_model=Health,
            responses={503: {"model": Health, "description": "no worker can take a render now"}})
async def ready(request: Request) -> JSONResponse:
    """200 when a render worker can take a render now; 503 otherwise (for a readiness probe:
    send no traffic while it fails)."""
    pool = request.state.pool
    is_ready = pool.ready
    body = Health(status=_status(pool), ready=is_ready, pool=PoolStatus(**pool.status()))
    return JSONResponse(body.model_dump(), status_code=200 if is_ready else 503)


@router.get("/limits", response_model=Limits)
async def limits(request: Request) -> Limits:
    """The service's limits (configurable, see docs/service.md) on top of the scene schema."""
    s = request.state.settings
    return Limits(
        max_body_bytes=s.max_body_bytes,
        max_duration_s=s.max_duration_s,
        max_events=s.max_events,
        max_score_events=s.max_score_events,
        score_formats=["gp3", "gp4", "gp5", "mid", "midi"],
        max_expanded_events=s.max_expanded_events,
        min_sample_rate=s.min_sample_rate,
        max_sample_rate=s.max_sample_rate,
        time_limit_base_s=s.time_limit_base_s,
        time_limit_per_audio_s=s.time_limit_per_audio_s,
        time_limit_per_estimated_s=s.time_limit_per_estimated_s,
        max_render_s=s.max_render_s,
        heavy_render_s=s.heavy_render_s,
        work_per_second=s.work_per_second,
        stream_formats=["wav"],
        formats=["wav", "flac", "ogg"],
        job_max_duration_s=s.job_max_duration_s,
        job_max_events=s.job_max_events,
        job_max_render_s=s.job_max_render_s,
        job_max_per_client=s.job_max_per_client,
        live_max_messages_per_s=s.live_max_messages_per_s,
    )
