"""Exception -> HTTP answer, in one place.

| cause                                  | status | why that one                                    |
| -------------------------------------- | ------ | ----------------------------------------------- |
| invalid scene, service limit           | 422    | pydantic's detail list, with a ``field`` added  |
| engine: simulation became non-finite   | 422    | deterministic for that scene: retrying won't help|
| body too large                         | 413    |                                                 |
| queue full / no worker free in time    | 503    | with Retry-After: the load is transient         |
| server shutting down                   | 503    |                                                 |
| render past its time limit             | 504    | the worker was killed and replaced              |
| worker process died mid-render         | 502    | the upstream (the worker) failed; it is replaced|
| unexpected engine exception            | 500    | a bug to fix, logged with its message           |
| client gone while its render waited/ran| (499)  | logged only: the render is cancelled            |
"""

from __future__ import annotations

import logging
import math
import re
from typing import Any

from fastapi import FastAPI, Request
from fastapi.encoders import jsonable_encoder
from fastapi.exceptions import RequestValidationError
from fastapi.responses import JSONResponse, Response

import engine

from .exceptions import ClientGone, PoolBusy, PoolClosed, RenderFailed, RenderTimeout, WorkerDied

log = logging.getLogger("service.errors")

# The engine's cross-field checks name the field at the start of their message:
# "Value error, events[2].time: 3.0 outside 0 <= time < 2.0".
_FIELD_IN_MESSAGE = re.compile(r"^(?:Value error, )?((?:[a-z_]+(?:\[\d+\])?\.)*[a-z_]+(?:\[\d+\])?): ")


def _event_tags() -> frozenset[str]:
    """The event ``type`` values the engine's schema knows (pydantic puts them into error locs)."""
    items = engine.Scene.model_json_schema()["properties"]["events"]["items"]
    return frozenset(items.get("discriminator", {}).get("mapping", {}))


_EVENT_TAGS = _event_tags()


def safe_json(value: Any) -> Any:
    """``value`` made writable as strict JSON: non-finite floats become their text (``"inf"``) and
    strings lose what UTF-8 cannot carry (a lone surrogate such as ``"\\ud800"``, which a JSON body
    may hold and an error message may echo, becomes its escape).  Every error body goes through
    it, so echoing the input can never break the answer."""
    if isinstance(value, float):
        return value if math.isfinite(value) else repr(value)
    if isinstance(value, str):
        try:
            value.encode("utf-8")
        except UnicodeEncodeError:
            return value.encode("utf-8", "backslashreplace").decode("utf-8")
        return value
    if isinstance(value, dict):
        return {safe_json(k): safe_json(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [safe_json(v) for v in value]
    return value


class SafeJSONResponse(JSONResponse):
    """A JSON response whose content is passed through ``safe_json`` first."""

    def render(self, content: Any) -> bytes:
        return super().render(safe_json(content))


def field_path(loc: tuple | list, msg: str) -> str:
    """A dotted path of the offending field, e.g. ``events[0].force`` (``""`` for the body)."""
    parts = list(loc)
    if parts and parts[0] == "body":
        parts = parts[1:]
    path = ""
    for i, p in enumerate(parts):
        if isinstance(p, int):
            path += f"[{p}]"
        elif (i and isinstance(parts[i - 1], int) and p in _EVENT_TAGS) or "[" in str(p):
            continue  # pydantic's union-member tag, not a field
        else:
            path += f".{p}" if path else str(p)
    if not path:
        m = _FIELD_IN_MESSAGE.match(msg)
        if m:
            path = m.group(1)
    return path


# A refusal stays short whatever it refuses: a client's or a converted score's value is echoed
# only while it is small, and at most MAX_ERRORS errors are listed (then a count of the rest), so
# that no request makes this process serialise megabytes on its event loop.
MAX_ERRORS = 20
MAX_INPUT_CHARS = 200
MAX_MESSAGE_CHARS = 1000  # a message quoting what it refuses (a preset name of 100 KB) is cut


def _short_text(text: str) -> str:
    return text if len(text) <= MAX_MESSAGE_CHARS else text[:MAX_MESSAGE_CHARS - 3] + "..."


def _too_big(value: Any, budget: int = MAX_INPUT_CHARS) -> bool:
    """Whether ``value`` would take more than about ``budget`` characters as JSON; stops as soon
    as it knows (a list of 20,000 events is not walked)."""
    stack = [value]
    while stack:
        v = stack.pop()
        if isinstance(v, str):
            budget -= len(v) + 2
        elif isinstance(v, dict):
            budget -= 2 + 4 * len(v)
            if budget >= 0:
                stack.extend(v.keys())
                stack.extend(v.values())
        elif isinstance(v, list | tuple):
            budget -= 2 + len(v)
            if budget >= 0:
                stack.extend(v)
        else:
            budget -= 8
        if budget < 0:
            return True
    return False


def _short_input(value: Any) -> Any:
    """The echoed input of an error, or what it was when it is too big to echo."""
    if not _too_big(value):
        return value
    if isinstance(value, str):
        return value[:MAX_INPUT_CHARS - 3] + "..."
    if isinstance(value, dict):
        return f"(an object of {len(value)} keys, not echoed)"
    if isinstance(value, list | tuple):
        return f"(a list of {len(value)} items, not echoed)"
    return f"(a {type(value).__name__}, not echoed)"


def portable_errors(errors: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Pydantic's errors as plain JSON data, for a worker to send to the API process: the first
    ``MAX_ERRORS``, each input and context shortened as the answer shows them (a score's scene
    can be megabytes), and the count of the others as the answer says it."""
    out = []
    for err in errors[:MAX_ERRORS]:
        item = {k: v for k, v in err.items() if k != "url"}
        if "input" in item:
            item["input"] = _short_input(item["input"])
        if "ctx" in item:
            item["ctx"] = {k: _short_input(v) for k, v in dict(item["ctx"]).items()}
        out.append(item)
    if len(errors) > MAX_ERRORS:
        out.append(_too_many(len(errors) - MAX_ERRORS))
    return safe_json(jsonable_encoder(out))


def _too_many(more: int) -> dict[str, Any]:
    return {"type": "too_many_errors", "loc": ["body"], "field": "",
            "msg": f"and {more} more errors", "message": f"and {more} more errors like "
            f"these (the first {MAX_ERRORS} are listed)"}


def _detail(errors: list[dict[str, Any]]) -> list[dict[str, Any]]:
    out = []
    counted = errors[-1] if errors and errors[-1].get("type") == "too_many_errors" else None
    if counted is not None:  # cut short by ``portable_errors``
        errors = errors[:-1]
    more = len(errors) - MAX_ERRORS
    for err in errors[:MAX_ERRORS]:
        item = dict(err)
        msg = str(item.get("msg", ""))
        if item.get("type") == "json_invalid":
            field = ""  # the loc holds a character position, not a field
            reason = (item.get("ctx") or {}).get("error")
            msg = f"{msg}: {reason}" if reason else msg
            loc = list(item.get("loc", ()))
            if len(loc) > 1 and isinstance(loc[1], int):
                msg += f" at character {loc[1]}"
        else:
            field = field_path(item.get("loc", ()), msg)
        item["field"] = field
        # One self-contained sentence for people: the field, then pydantic's text with the range.
        text = msg.removeprefix("Value error, ")
        item["message"] = _short_text(
            text if not field or text.startswith(field) else f"{field}: {text}")
        item["msg"] = _short_text(str(item.get("msg", "")))
        if tuple(item.get("loc", ())) == ("body",):
            item.pop("input", None)  # the whole scene: no need to echo it back
        elif "input" in item:
            item["input"] = _short_input(item["input"])
        if "ctx" in item:
            item["ctx"] = {k: _short_input(v) for k, v in dict(item["ctx"]).items()}
        item.pop("url", None)
        out.append(item)
    if more > 0:
        out.append(_too_many(more))
    elif counted is not None:
        out.append(counted)
    return safe_json(jsonable_encoder(out))


async def validation_error(request: Request, exc: RequestValidationError) -> JSONResponse:
    return SafeJSONResponse({"detail": _detail(list(exc.errors()))}, status_code=422)


def _message(status: int, message: str, headers: dict[str, str] | None = None) -> JSONResponse:
    return SafeJSONResponse({"detail": message}, status_code=status, headers=headers)


def install(app: FastAPI, retry_after_s: int) -> None:
    app.add_exception_handler(RequestValidationError, validation_error)  # type: ignore[arg-type]

    async def busy(request: Request, exc: Exception) -> JSONResponse:
        return _message(503, str(exc), {"Retry-After": str(retry_after_s)})

    async def timeout(request: Request, exc: Exception) -> JSONResponse:
        return _message(504, str(exc))

    async def died(request: Request, exc: Exception) -> JSONResponse:
        return _message(502, str(exc))

    async def failed(request: Request, exc: Exception) -> JSONResponse:
        assert isinstance(exc, RenderFailed)
        if exc.kind == "non_finite":
            return _message(422, f"the simulation of this scene became unstable ({exc.message}); "
                                 "lower the forces or use quality 'high'")
        if exc.kind == "invalid":
            return _message(422, exc.message)
        log.error("engine failure", extra={"fields": {
            "request_id": getattr(request.state, "request_id", None), "error": exc.message}})
        return _message(500, f"the engine failed on this scene: {exc.message}")

    async def gone(request: Request, exc: Exception) -> Response:
        # nobody reads this answer; 499 (nginx's "client closed request") marks it in the logs
        return Response(status_code=499)

    app.add_exception_handler(ClientGone, gone)
    app.add_exception_handler(PoolBusy, busy)
    app.add_exception_handler(PoolClosed, busy)
    app.add_exception_handler(RenderTimeout, timeout)
    app.add_exception_handler(WorkerDied, died)
    app.add_exception_handler(RenderFailed, failed)
