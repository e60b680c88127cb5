"""Pure ASGI middleware: request ids with access logs, and the request body size limit.

Pure ASGI rather than ``BaseHTTPMiddleware``: the access log of a stream must be written when its
last byte is sent, not when its headers are, and the body limit must act while the body is read.
"""

from __future__ import annotations

import json
import logging
import re
import time
import uuid
from typing import Any

from starlette.exceptions import HTTPException
from starlette.types import ASGIApp, Message, Receive, Scope, Send

from .exceptions import StreamAborted

access_log = logging.getLogger("service.access")

REQUEST_ID_HEADER = "x-request-id"
# A client's own id is echoed if it is short and harmless in logs and headers.
_CLIENT_ID = re.compile(r"^[A-Za-z0-9._:-]{1,128}$")


def _header(scope: Scope, name: bytes) -> str | None:
    for key, value in scope.get("headers", []):
        if key == name:
            return value.decode("latin-1")
    return None


def _only_stream_aborted(exc: BaseException) -> bool:
    if isinstance(exc, StreamAborted):
        return True
    if isinstance(exc, BaseExceptionGroup):
        return all(_only_stream_aborted(e) for e in exc.exceptions)
    return False


class RequestContextMiddleware:
    """Gives every request an id (``X-Request-ID``, echoed) and writes one JSON access line;
    tells the client how long the server held the request before its answer's headers
    (``Server-Timing: app;dur=MS``, the W3C header: from the request's arrival at this
    middleware, so a client can tell the server's time from its own and the network's).

    Handlers add ``render_seconds`` and ``audio_seconds`` to ``request.state``; the line then
    carries the real-time factor (audio seconds per second of rendering).
    """

    def __init__(self, app: ASGIApp):
        self.app = app

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        client_id = _header(scope, REQUEST_ID_HEADER.encode())
        rid = client_id if client_id and _CLIENT_ID.match(client_id) else uuid.uuid4().hex
        state: dict[str, Any] = scope.setdefault("state", {})
        state["request_id"] = rid
        t0 = time.perf_counter()
        info: dict[str, Any] = {"status": None, "bytes": 0, "logged": False}

        async def send_wrapper(message: Message) -> None:
            if message["type"] == "http.response.start":
                info["status"] = message["status"]
                headers = list(message.get("headers", []))
                headers.append((REQUEST_ID_HEADER.encode(), rid.encode()))
                dur_ms = 1000 * (time.perf_counter() - t0)
                headers.append((b"server-timing", f"app;dur={dur_ms:.1f}".encode()))
                message = {**message, "headers": headers}
            elif message["type"] == "http.response.body":
                info["bytes"] += len(message.get("body", b""))
            await send(message)
            if message["type"] == "http.response.body" and not message.get("more_body", False):
                self._log(scope, state, info, t0, None)

        try:
            await self.app(scope, receive, send_wrapper)
        except BaseException as exc:
            if info["status"] is not None and _only_stream_aborted(exc):
                # The header is out; returning without finishing the body makes the server close
                # the connection, which is how a client learns that the stream is incomplete.
                self._log(scope, state, info, t0, str(exc))
                return
            if info["status"] is None:
                info["status"] = 500  # the server's error middleware answers it
            self._log(scope, state, info, t0, f"{type(exc).__name__}: {exc}")
            raise
        if not info["logged"]:
            self._log(scope, state, info, t0, "response not completed (client disconnected)")

    @staticmethod
    def _log(scope: Scope, state: dict[str, Any], info: dict[str, Any], t0: float,
             error: str | None) -> None:
        if info["logged"]:
            return
        info["logged"] = True
        fields: dict[str, Any] = {
            "request_id": state.get("request_id"),
            "method": scope.get("method"),
            "path": scope.get("path"),
            "status": info["status"],
            "bytes": info["bytes"],
            "duration_ms": round(1000 * (time.perf_counter() - t0), 2),
        }
        client = scope.get("client")
        if client:
            fields["client"] = client[0]
        render_s = state.get("render_seconds")
        audio_s = state.get("audio_seconds")
        if render_s is not None:
            # 6 decimals, as X-Render-Seconds: a fast render is a few ms, which 4 would round by
            # several per cent
            fields["render_seconds"] = round(render_s, 6)
        if audio_s is not None and not error:
            fields["audio_seconds"] = audio_s
            if render_s:
                fields["realtime_factor"] = round(audio_s / render_s, 2)
        if error:
            fields["error"] = error
        access_log.info("request", extra={"fields": fields})


class BodyTooLarge(HTTPException):
    def __init__(self, limit: int, size: int | None = None):
        got = f"{size} bytes" if size is not None else "more"
        super().__init__(
            status_code=413,
            detail=f"request body: {got} exceeds the limit of {limit} bytes "
            "(GUITAR_MAX_BODY_BYTES)",
        )


class BodyLimitMiddleware:
    """413 for a body larger than ``max_bytes``: at once from Content-Length, or while reading."""

    def __init__(self, app: ASGIApp, max_bytes: int):
        self.app = app
        self.max_bytes = max_bytes

    async def __call__(self, scope: Scope, receive: Receive, send: Send) -> None:
        if scope["type"] != "http":
            await self.app(scope, receive, send)
            return
        declared = _header(scope, b"content-length")
        if declared is not None and declared.isdigit() and int(declared) > self.max_bytes:
            await self._reject(send, BodyTooLarge(self.max_bytes, int(declared)))
            return
        seen = 0

        async def limited_receive() -> Message:
            nonlocal seen
            message = await receive()
            if message["type"] == "http.request":
                seen += len(message.get("body", b""))
                if seen > self.max_bytes:
                    # Raised inside the body read; FastAPI passes HTTPExceptions through to the
                    # exception handlers, which answer 413.
                    raise BodyTooLarge(self.max_bytes)
            return message

        await self.app(scope, limited_receive, send)

    @staticmethod
    async def _reject(send: Send, exc: BodyTooLarge) -> None:
        body = json.dumps({"detail": exc.detail}).encode()
        await send({"type": "http.response.start", "status": 413, "headers": [
            (b"content-type", b"application/json"),
            (b"content-length", str(len(body)).encode()),
            (b"connection", b"close"),
        ]})
        await send({"type": "http.response.body", "body": body})
