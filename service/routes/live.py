"""WS /live: the guitar played over a websocket (``../shared/API.md``, "Live play").

Protocol (docs/service.md, "Live play", has it with examples):

* client -> server, text (JSON): first ``{"type": "open", "preset": ..., "sample_rate": ...,
  "block_frames": ..., "quality": ..., "model": ...}`` (``engine.live_events.LiveOpen``; ``model``
  ``"fdtd"``, the default, or ``"waveguide"``), then events: the scene's
  event objects without ``time`` (``offset``: frames into the next block; ``release``: seconds after
  the event), and ``{"type": "release", "string": s, "what": ...}``.  Any message may carry an
  ``id`` (a string or number); the server answers it with an ``ack`` naming the frame it acts at.
* server -> client, text (JSON): ``{"type": "opened", ...}`` (the session's rate, block, delay and
  lead), ``{"type": "ack", "id": ..., "frame": n}``, and ``{"type": "error", "field": ...,
  "message": ..., "id": ...}`` for a message that cannot be played (the session goes on).
* server -> client, binary: one block each: an 8-byte little-endian unsigned frame index of its first
  sample, then ``block_frames`` float32 little-endian mono samples at the fixed gain
  (``engine.FIXED_GAIN``), paced to real time ``GUITAR_LIVE_LEAD_MS`` ahead.
* closes: 1000 when the client closes; 1013 (try again later) beyond ``GUITAR_MAX_LIVE_SESSIONS``
  or when no live worker is ready within ``GUITAR_LIVE_START_TIMEOUT_S`` (the first session of a
  server starts them and waits); 4408 after ``GUITAR_LIVE_IDLE_TIMEOUT_S`` without a message;
  1011 if the session's worker failed (it is replaced); 1008 if the client falls more than 2 s
  behind reading the blocks; 4429 after more than ``GUITAR_LIVE_MAX_MESSAGES_PER_S`` messages
  (of any kind, valid or not) within a second.
"""

from __future__ import annotations

import asyncio
import json
import struct
import time
from collections import deque
from typing import Any

from fastapi import APIRouter, Request, WebSocket
from prometheus_client import Histogram
from starlette.websockets import WebSocketDisconnect, WebSocketState

import engine

from ..live import LiveBusy, LivePool, LiveSession, LiveUnavailable

router = APIRouter(tags=["live"])

CLOSE_BUSY = 1013
CLOSE_IDLE = 4408
CLOSE_FAILED = 1011
CLOSE_SLOW = 1008
CLOSE_FLOOD = 4429
BACKLOG_S = 2.0  # a client that falls this far behind reading the blocks is closed (1008)
MAX_MESSAGE_BYTES = 16 * 1024
_HEADER = struct.Struct("<Q")


class _Idle(Exception):
    pass


async def _error(ws: WebSocket, field: str, message: str, ident: Any = None) -> None:
    body: dict[str, Any] = {"type": "error", "field": field, "message": message}
    if ident is not None:
        body["id"] = ident
    await ws.send_json(body)


class _Flood(Exception):
    pass


class _MessageRate:
    """Messages of any kind in the last second; past ``per_s`` the session is closed (4429):
    answering a flood with one error each would only feed it."""

    def __init__(self, per_s: int):
        self.per_s = per_s
        self._times: deque[float] = deque()

    def count(self) -> None:
        now = time.monotonic()
        while self._times and now - self._times[0] >= 1.0:
            self._times.popleft()
        self._times.append(now)
        if len(self._times) > self.per_s:
            raise _Flood(f"more than {self.per_s} messages in a second "
                         "(GUITAR_LIVE_MAX_MESSAGES_PER_S)")


def _reaped(task: asyncio.Task) -> asyncio.Task:
    """``task``, whose exception (a disconnect it saw while the other task ended the session) is
    retrieved when it ends: asyncio would otherwise log it with a traceback."""
    task.add_done_callback(lambda t: t.cancelled() or t.exception())
    return task


async def _receive(ws: WebSocket, idle_s: float, rate: _MessageRate) -> dict | None:
    """The next message as a JSON object; None after an error was answered; raises ``_Idle``,
    ``_Flood`` or ``WebSocketDisconnect``."""
    try:
        msg = await asyncio.wait_for(ws.receive(), idle_s)
    except TimeoutError:
        raise _Idle from None
    if msg["type"] == "websocket.disconnect":
        raise WebSocketDisconnect(msg.get("code", 1000))
    rate.count()
    text = msg.get("text")
    if text is None:
        await _error(ws, "message", "binary messages are not taken: send events as JSON text")
        return None
    if len(text) > MAX_MESSAGE_BYTES:
        await _error(ws, "message", f"{len(text)} bytes; at most {MAX_MESSAGE_BYTES} per message")
        return None
    try:
        body = json.loads(text)
    except ValueError as exc:
        await _error(ws, "message", f"not JSON: {exc}")
        return None
    if not isinstance(body, dict):
        await _error(ws, "message", "a message is a JSON object with a 'type'")
        return None
    return body


def _ident(body: dict) -> tuple[Any, str | None]:
    ident = body.pop("id", None)
    if ident is None:
        return None, None
    if isinstance(ident, bool) or not isinstance(ident, str | int | float) or len(str(ident)) > 64:
        return None, "a string or number of at most 64 characters"
    return ident, None


@router.get("/live/status")
async def live_status(request: Request) -> dict[str, Any]:
    """The live-session workers: whether they have started (with the first session, or with the
    server under GUITAR_LIVE_PRESTART), how many are ready, their process ids, and the sessions
    open against the limit."""
    pool: LivePool = request.state.live
    return {"ready": pool.ready, **pool.status(), "pids": pool.pids()}


@router.websocket("/live")
async def live(ws: WebSocket) -> None:
    pool: LivePool = ws.state.live
    settings = ws.state.settings
    idle_s = settings.live_idle_timeout_s
    await ws.accept()
    session: LiveSession | None = None
    rate = _MessageRate(settings.live_max_messages_per_s)
    try:
        preset, block_frames = None, 0
        while session is None:  # until a valid open message
            body = await _receive(ws, idle_s, rate)
            if body is None:
                continue
            body.pop("id", None)
            if body.get("type", "open") != "open":
                await _error(ws, "type", f"open the session first (type 'open'); got "
                                         f"{body.get('type')!r} before it")
                continue
            try:
                opened = engine.parse_live_open(body)
            except engine.LiveError as exc:
                await _error(ws, exc.field, exc.message)
                continue
            try:
                session = await pool.open(opened.model_dump(exclude_unset=True))
            except (LiveBusy, LiveUnavailable) as exc:
                await ws.close(CLOSE_BUSY, str(exc)[:120])
                return
            first = await session.messages.get()
            if first[0] != "opened":
                pool.end(session)
                await ws.close(CLOSE_FAILED, "the session could not start")
                return
            await ws.send_json({"type": "opened", **first[2]})
            preset = engine.Scene(duration=1.0, guitar=opened.scene_guitar()).preset()
            block_frames = opened.block_frames
        backlog = max(8, int(BACKLOG_S * opened.sample_rate / block_frames))
        sender = _reaped(asyncio.create_task(_send(ws, session, backlog,
                                                   ws.state.metrics.live_relay)))
        try:
            await _events(ws, pool, session, preset, block_frames, idle_s,
                          settings.live_max_events_per_s, sender, rate)
        finally:
            sender.cancel()
    except _Idle:
        await _close(ws, CLOSE_IDLE, f"idle: no message for {idle_s:g} s")
    except (WebSocketDisconnect, OSError):  # the client has gone (uvicorn: ClientDisconnected)
        pass
    except _Failed as exc:
        await _close(ws, CLOSE_FAILED, str(exc)[:120])
    except _SlowClient as exc:
        await _close(ws, CLOSE_SLOW, str(exc)[:120])
    except _Flood as exc:
        await _close(ws, CLOSE_FLOOD, str(exc)[:120])
    finally:
        if session is not None:
            pool.end(session)
    await _close(ws, 1000, "")


class _Failed(Exception):
    pass


class _SlowClient(Exception):
    pass


async def _close(ws: WebSocket, code: int, reason: str) -> None:
    if ws.application_state != WebSocketState.DISCONNECTED:
        try:
            await ws.close(code, reason)
        except (RuntimeError, WebSocketDisconnect, OSError):
            pass


async def _events(ws: WebSocket, pool: LivePool, session: LiveSession, preset: Any,
                  block_frames: int, idle_s: float, per_s: int, sender: asyncio.Task,
                  rate: _MessageRate) -> None:
    recent: deque[float] = deque()
    while True:
        receive = _reaped(asyncio.ensure_future(_receive(ws, idle_s, rate)))
        done, _ = await asyncio.wait({receive, sender}, return_when=asyncio.FIRST_COMPLETED)
        if sender in done:  # the session ended on the worker's side
            receive.cancel()
            exc = sender.exception()
            if exc is not None:
                raise exc
            return
        body = receive.result()
        if body is None:
            continue
        ident, bad = _ident(body)
        if bad:
            await _error(ws, "id", bad)
            continue
        if body.get("type") == "open":
            await _error(ws, "type", "the session is already open", ident)
            continue
        now = time.monotonic()
        while recent and now - recent[0] >= 1.0:
            recent.popleft()
        if len(recent) >= per_s:
            await _error(ws, "message", f"too many events: at most {per_s} per second", ident)
            continue
        try:
            engine.parse_live_event(body, preset, block_frames)
        except engine.LiveError as exc:
            await _error(ws, exc.field, exc.message, ident)
            continue
        recent.append(now)
        if ident is not None:
            body["id"] = ident
        pool.event(session, body)


async def _send(ws: WebSocket, session: LiveSession, backlog: int, relay: Histogram) -> None:
    """The session's messages to the client; each block's relay timed (``relay``: from its
    sending by the live worker to its hand-over to the socket)."""
    while True:
        if session.messages.qsize() > backlog:
            raise _SlowClient(f"the client fell more than {BACKLOG_S:g} s behind reading the blocks")
        msg = await session.messages.get()
        kind = msg[0]
        try:
            if kind == "block":
                await ws.send_bytes(_HEADER.pack(msg[2]) + msg[3])
                relay.observe(time.monotonic() - msg[4])
            elif kind == "ack":
                await ws.send_json({"type": "ack", "id": msg[2], "frame": msg[3]})
            elif kind == "error":
                await _error(ws, msg[2], msg[3], msg[4])
        except (WebSocketDisconnect, RuntimeError, OSError):
            return  # the client has gone
        if kind == "failed":
            raise _Failed(f"the session failed: {msg[2]}")
        elif kind == "died":
            raise _Failed("the live worker died; it is being replaced")
