"""Readiness of the render workers, and the limits this server puts on a scene."""

from __future__ import annotations

from fastapi import APIRouter, Request
from fastapi.responses import JSONResponse

from ..schemas import Health, Limits, PoolStatus

router = APIRouter(tags=["service"])


@router.get("/health", response_model=Health,
            responses={503: {"model": Health, "description": "workers still warming up"}})
async def health(request: Request) -> JSONResponse:
    """200 once every render worker has warmed up (compiled or loaded its kernels), and from then on
    while at least one worker is ready (a replacement warms up in the background); else 503."""
    pool = request.state.pool
    ready = pool.ready
    body = Health(status="ok" if ready else "starting", ready=ready,
                  pool=PoolStatus(**pool.status()))
    return JSONResponse(body.model_dump(), status_code=200 if ready else 503)


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
        min_sample_rate=s.min_sample_rate,
        max_sample_rate=s.max_sample_rate,
        time_limit_base_s=s.time_limit_base_s,
        time_limit_per_audio_s=s.time_limit_per_audio_s,
        stream_formats=["wav"],
        formats=["wav", "flac", "ogg"],
        job_max_duration_s=s.job_max_duration_s,
        job_max_events=s.job_max_events,
    )
