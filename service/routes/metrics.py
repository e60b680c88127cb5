"""GET /metrics: Prometheus' text format (``service.metrics`` says what is counted)."""

from __future__ import annotations

from fastapi import APIRouter, Request, Response

router = APIRouter(tags=["service"])


@router.get("/metrics", response_class=Response,
            responses={200: {"content": {"text/plain": {}}}})
async def metrics(request: Request) -> Response:
    """Requests, renders by outcome, render seconds, jobs by status, queue depth, busy and ready
    workers and worker restarts, in Prometheus' text exposition format."""
    body, content_type = request.state.metrics.exposition()
    return Response(body, media_type=content_type)
