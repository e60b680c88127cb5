"""POST /render (a whole file) and POST /render/stream (WAV sent as it is computed).

Handlers stay thin: validate (engine schema via FastAPI, then the service's limits), hand the scene
to the worker pool, turn the result into a response.  Status codes for failures: ``service.errors``.
"""

from __future__ import annotations

from collections.abc import AsyncIterator, Callable
from typing import Annotated, Any

from fastapi import APIRouter, Body, Request, Response
from fastapi.responses import StreamingResponse
from starlette.requests import ClientDisconnect
from starlette.types import Receive, Scope, Send

import engine

from .. import audio
from ..examples import scene_examples, stream_examples
from ..responses import (
    ERROR_RESPONSES,
    realtime_factor,
    scene_payload,
    seconds,
    warnings_header,
    while_connected,
)
from ..validation import StrictJSONRoute, check_limits, check_streamable

router = APIRouter(route_class=StrictJSONRoute, tags=["render"])


@router.post(
    "/render",
    response_class=Response,
    responses={
        200: {
            "description": "the audio file (with output.stems, a zip of it and each "
                           "string's file: docs/service.md); headers X-Render-Seconds, "
                           "X-Realtime-Factor, "
                           "X-Render-Warnings when the scene has fingers pressing too lightly to "
                           "seat their strings (a JSON array of messages) and, with diagnostics, "
                           "X-Energy-Error",
            "content": {t: {} for t in (*audio.MEDIA_TYPES.values(), "application/zip")},
        },
        **ERROR_RESPONSES,
    },
)
async def render(
    scene: Annotated[engine.Scene, Body(openapi_examples=scene_examples())], request: Request
) -> Response:
    """Render a scene to a WAV, FLAC or Ogg Vorbis file."""
    settings, pool = request.state.settings, request.state.pool
    estimated_s = check_limits(scene, settings)
    out = await while_connected(request, pool.render(
        {
            "scene": scene_payload(scene),
            "diagnostics": scene.diagnostics,
            "sample_rate": scene.sample_rate,
            "format": scene.output.format,
            "subtype": scene.output.subtype,
            "channels": scene.output.channels,
        },
        settings.time_limit_s(scene.duration, estimated_s),
        heavy=estimated_s > settings.heavy_render_s, cost=estimated_s,
    ), settings.disconnect_poll_s)
    audio_s = out.frames / scene.sample_rate
    request.state.render_seconds, request.state.audio_seconds = out.render_seconds, audio_s
    headers = {
        "X-Render-Seconds": seconds(out.render_seconds),
        "X-Realtime-Factor": realtime_factor(audio_s, out.render_seconds),
        "Content-Disposition": 'inline; filename="guitar.'
                               f'{"zip" if scene.output.stems else scene.output.format}"',
        **warnings_header(out.warnings),
    }
    if out.energy_error is not None:
        headers["X-Energy-Error"] = repr(out.energy_error)  # e.g. 6.24e-15
    return Response(out.data, media_type=audio.media_type(scene.output.format, scene.output.stems),
                    headers=headers)


class _StreamResponse(StreamingResponse):
    """Calls ``on_close`` however the response ends: done, client gone, or never started."""

    def __init__(self, content: AsyncIterator[bytes], on_close: Callable[[], None],
                 **kwargs: Any):
        super().__init__(content, **kwargs)
        self._on_close = on_close

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        try:
            await super().__call__(scope, receive, send)
        except ClientDisconnect:
            pass  # nobody to answer; on_close stops the render
        finally:
            self._on_close()


@router.post(
    "/render/stream",
    response_class=StreamingResponse,
    responses={
        200: {
            "description": "a WAV file sent block by block as the engine computes it, at the "
                           "fixed gain; Content-Length is exact. X-Render-Seconds is the time to "
                           "the first block (prepare + first block): the total is not known when "
                           "headers are sent. X-Render-Warnings as for /render",
            "content": {"audio/wav": {}},
        },
        **ERROR_RESPONSES,
    },
)
async def render_stream(
    scene: Annotated[engine.Scene, Body(openapi_examples=stream_examples())], request: Request
) -> Response:
    """Stream a scene as WAV (PCM_16 unless ``output.subtype`` says otherwise). The bytes equal
    those of ``POST /render`` for the same scene with ``output.normalize: false``; ``normalize``
    and ``diagnostics`` are ignored here, and ``flac``/``ogg`` are refused (422)."""
    settings, pool = request.state.settings, request.state.pool
    estimated_s = check_limits(scene, settings)
    check_streamable(scene)
    rate, subtype, channels = scene.sample_rate, scene.output.subtype, scene.output.channels
    frames = engine.frame_count(scene)  # exactly what the worker's blocks add up to
    header = audio.wav_header(frames, rate, subtype, channels)
    scene_json = scene_payload(scene)  # the worker turns diagnostics off (a stream has none)
    # A client gone before the first block cancels the stream in its worker (or its place in
    # the queue); after, the response's on_close does.
    stream = await while_connected(request, pool.stream(
        {"scene": scene_json, "frames": frames, "subtype": subtype, "channels": channels},
        settings.time_limit_s(scene.duration, estimated_s),
        heavy=estimated_s > settings.heavy_render_s, cost=estimated_s), settings.disconnect_poll_s)
    audio_s = frames / rate
    request.state.audio_seconds = audio_s
    headers = {
        "Content-Length": str(audio.wav_size(frames, subtype, channels)),
        "X-Render-Seconds": seconds(stream.first_block_seconds),
        "Content-Disposition": 'inline; filename="guitar.wav"',
        **warnings_header(stream.warnings),
    }

    async def body() -> AsyncIterator[bytes]:
        yield header
        try:
            async for chunk in stream.chunks():
                yield chunk
        finally:
            request.state.render_seconds = stream.render_seconds

    return _StreamResponse(
        body(),
        on_close=stream.close,
        media_type="audio/wav",
        headers=headers,
    )
