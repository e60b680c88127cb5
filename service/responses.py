"""What the render routes (``/render``, ``/render/stream``, ``/render/score``, ``/jobs``) answer
alike: the documented error responses, the scene as a worker receives it, and the response headers
(``X-Render-Seconds``, ``X-Realtime-Factor``, ``X-Render-Warnings``)."""

from __future__ import annotations

import asyncio
import json
from collections.abc import Awaitable
from typing import Any

from fastapi import Request

import engine

from .exceptions import ClientGone

ERROR_RESPONSES: dict[int | str, dict[str, Any]] = {
    413: {"description": "request body too large"},
    422: {"description": "invalid scene or outside the service's limits; `detail[].field` names "
                         "the field"},
    502: {"description": "the render worker died during the render (it is replaced)"},
    503: {"description": "all workers busy and the queue full (see Retry-After)"},
    504: {"description": "the render ran past its time limit and was stopped"},
}


def scene_payload(scene: engine.Scene) -> dict[str, Any]:
    """The scene as the worker re-parses it: only the fields the client set (the rest are the
    same defaults again).  A full dump of a scene with ``tracks`` would also carry the default
    top-level ``guitar``, which the schema refuses beside ``tracks``."""
    return scene.model_dump(mode="json", exclude_unset=True)


def seconds(x: float) -> str:
    return f"{x:.6f}"


def realtime_factor(audio_s: float, render_s: float) -> str:
    return f"{audio_s / render_s:.2f}" if render_s > 0 else "inf"


MAX_HEADER_WARNINGS = 10  # a scene of 500 light taps would otherwise send a 90 kB header


def warnings_header(warnings: list[str], name: str = "X-Render-Warnings") -> dict[str, str]:
    """``X-Render-Warnings``: a JSON array of what the scene asks for that may not sound as meant
    (``engine.RenderResult.warnings``: a finger pressing too lightly to seat its string), when
    there is any; the first ``MAX_HEADER_WARNINGS`` and a count of the rest.  The worker works
    them out with the render, inside its time limit.  ``X-Score-Warnings`` (what a score asks
    for that its scene cannot play) takes the same shape under its own ``name``."""
    if len(warnings) > MAX_HEADER_WARNINGS:
        more = len(warnings) - MAX_HEADER_WARNINGS
        warnings = [*warnings[:MAX_HEADER_WARNINGS], f"and {more} more warnings like these"]
    return {name: json.dumps(warnings)} if warnings else {}


async def while_connected(request: Request, work: Awaitable[Any], poll_s: float) -> Any:
    """Await ``work`` (the pool's render or the start of a stream), checking every ``poll_s``
    that the client is still there; if it has gone, cancel ``work`` (a queued render leaves the
    queue, a stream is cancelled in its worker, a heavy render's worker is stopped)."""
    task = asyncio.ensure_future(work)
    try:
        while True:
            done, _ = await asyncio.wait({task}, timeout=poll_s)
            if done:
                return task.result()
            if await request.is_disconnected():
                raise ClientGone()
    finally:
        if not task.done():
            task.cancel()
            try:
                await task
            except BaseException:  # noqa: S110 - cancelled or failed: the client is gone anyway
                pass
