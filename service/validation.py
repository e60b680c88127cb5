"""What the service checks on top of the engine's scene schema.

* Strict JSON: Python's ``json`` (which FastAPI uses) accepts the non-standard tokens ``NaN``,
  ``Infinity`` and ``-Infinity``, turns a literal such as ``1e309`` into infinity and refuses an
  integer of 4,300 digits or more with no location.  These are refused here, before validation,
  with the location of each (a 422 naming the field), as are integer literals of more than
  ``MAX_INT_DIGITS`` digits.
* Service limits (``Settings``): duration, number of events, sample rate.  They are reported in the
  same shape as pydantic's own errors, so a client handles one format.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Coroutine, Iterator
from dataclasses import asdict, dataclass
from typing import Any

from fastapi import Request, Response
from fastapi.exceptions import RequestValidationError
from fastapi.routing import APIRoute
from starlette.requests import ClientDisconnect

import engine

from .config import Settings
from .exceptions import ClientGone


class _NonFinite:
    """Stands in for a NaN/Infinity token (or a number literal out of range) while the body is
    scanned; ``why`` ends the message."""

    def __init__(self, token: str, why: str = "numbers must be finite"):
        self.token = token
        self.why = why


# Integer literals longer than this are out of range for every field (the longest a schema field
# takes has 9 digits); Python's int() refuses 4,300 digits and more with a bare ValueError.
MAX_INT_DIGITS = 100


def _parse_float(text: str) -> Any:
    x = float(text)
    if math.isfinite(x):
        return x
    shown = text if len(text) <= 40 else text[:37] + "..."
    return _NonFinite(shown, "the literal overflows a double (about 1.8e308); numbers must be finite")


def _parse_int(text: str) -> Any:
    digits = len(text.lstrip("-"))
    if digits > MAX_INT_DIGITS:
        return _NonFinite(f"an integer of {digits} digits",
                          f"integer literals have at most {MAX_INT_DIGITS} digits")
    return int(text)


def _nonfinite_locations(data: Any) -> Iterator[tuple[tuple[str | int, ...], str]]:
    # Iterative: the body size limit bounds the depth, but not below Python's recursion limit.
    stack: list[tuple[tuple[str | int, ...], Any]] = [((), data)]
    while stack:
        loc, value = stack.pop()
        if isinstance(value, _NonFinite):
            yield loc, value
        elif isinstance(value, dict):
            stack.extend(((*loc, k), v) for k, v in value.items())
        elif isinstance(value, list):
            stack.extend(((*loc, i), v) for i, v in enumerate(value))


async def reject_nonfinite_json(request: Request) -> None:
    body = await request.body()
    if not body:
        return
    try:
        data = json.loads(body, parse_constant=_NonFinite, parse_float=_parse_float,
                          parse_int=_parse_int)
    except RecursionError:
        raise RequestValidationError([{
            "type": "json_invalid", "loc": ("body",), "msg": "JSON nested too deeply",
            "input": None}]) from None
    except ValueError:
        return  # malformed: FastAPI's own parse answers it (422 json_invalid, with the position)
    errors = [
        {
            "type": "finite_number",
            "loc": ("body", *loc),
            "msg": f"{bad.token} is not valid here: {bad.why}",
            "input": bad.token,
        }
        for loc, bad in sorted(_nonfinite_locations(data), key=lambda x: str(x[0]))
    ]
    if errors:
        raise RequestValidationError(errors)


class StrictJSONRoute(APIRoute):
    """An API route whose JSON body may not contain NaN or Infinity tokens."""

    def get_route_handler(self) -> Callable[[Request], Coroutine[Any, Any, Response]]:
        handler = super().get_route_handler()

        async def strict_handler(request: Request) -> Response:
            try:
                await reject_nonfinite_json(request)
            except ClientDisconnect:
                raise ClientGone() from None  # left while sending its body: nobody to answer
            return await handler(request)

        return strict_handler


@dataclass(frozen=True)
class Figures:
    """What the limits and the routes read of a valid scene.  A score's scene is parsed, checked
    and measured in a worker (``service.worker``, job ``score``), which sends these figures and
    the scene's JSON: the API process never holds a whole song's scene, whose parsing would stop
    its event loop for tens of milliseconds."""

    duration: float
    sample_rate: int
    events: int  # over all tracks
    expanded: int  # single-string events (``engine.expanded_event_count``)
    tracks: bool  # a scene of tracks (the field a count is reported at)
    quality: str
    work: float  # ``engine.estimate_cost``
    per_second: float
    strings: int
    format: str
    subtype: str | None
    channels: int
    stems: bool
    diagnostics: bool

    @classmethod
    def of(cls, scene: engine.Scene) -> Figures:
        cost = engine.estimate_cost(scene)
        return cls(duration=scene.duration, sample_rate=scene.sample_rate,
                   events=scene.event_count(), expanded=engine.expanded_event_count(scene),
                   tracks=scene.tracks is not None, quality=scene.quality, work=cost.work,
                   per_second=cost.per_second, strings=len(cost.strings),
                   format=scene.output.format, subtype=scene.output.subtype,
                   channels=scene.output.channels, stems=bool(scene.output.stems),
                   diagnostics=bool(scene.diagnostics))

    def as_dict(self) -> dict[str, Any]:
        return asdict(self)


def _error(field: str, kind: str, msg: str, value: Any, ctx: dict[str, Any]) -> dict[str, Any]:
    return {"type": kind, "loc": ("body", *field.split(".")), "msg": msg, "input": value,
            "ctx": ctx}


def check_limits(scene: engine.Scene | Figures, settings: Settings,
                 max_events: int | None = None) -> float:
    """Raise a 422 for a valid scene (or a worker's figures of one) that is outside this server's
    limits (``max_events``: a limit other than ``settings.max_events``, e.g. a score's), its
    estimated cost included; return the estimated seconds of its render."""
    if isinstance(scene, engine.Scene):
        scene = Figures.of(scene)
    errors = []
    limit = settings.max_events if max_events is None else max_events
    events = scene.events
    if scene.duration > settings.max_duration_s:
        errors.append(_error(
            "duration", "less_than_equal",
            f"Input should be less than or equal to {settings.max_duration_s:g} "
            "(service limit GUITAR_MAX_DURATION_S)", scene.duration,
            {"le": settings.max_duration_s}))
    if events > limit:
        which = "GUITAR_MAX_EVENTS" if max_events is None else "GUITAR_MAX_SCORE_EVENTS"
        errors.append(_error(
            "tracks" if scene.tracks else "events", "too_long",
            f"List should have at most {limit} items "
            f"(service limit {which}, counted over all tracks), not {events}", events,
            {"max_length": limit}))
    if not settings.min_sample_rate <= scene.sample_rate <= settings.max_sample_rate:
        errors.append(_error(
            "sample_rate", "range",
            f"Input should be between {settings.min_sample_rate} and "
            f"{settings.max_sample_rate} Hz (service limits GUITAR_MIN_SAMPLE_RATE, "
            "GUITAR_MAX_SAMPLE_RATE)", scene.sample_rate,
            {"ge": settings.min_sample_rate, "le": settings.max_sample_rate}))
    if not errors:
        expanded = scene.expanded
        if expanded > settings.max_expanded_events:
            errors.append(_error(
                "events", "too_long",
                f"the events expand to {expanded} single-string events (a strum counts once per "
                "string it plucks, a mute with no string once per string); at most "
                f"{settings.max_expanded_events} (service limit GUITAR_MAX_EXPANDED_EVENTS)",
                expanded, {"max_length": settings.max_expanded_events}))
    if errors:
        raise RequestValidationError(errors)
    seconds = settings.estimated_seconds(scene.work)
    if seconds > settings.max_render_s:
        most = settings.max_render_s * settings.work_per_second / scene.per_second
        raise RequestValidationError([_error(
            "duration", "render_cost",
            f"this scene would take about {seconds:.0f} s to render ({scene.strings} strings "
            f"simulated at quality {scene.quality!r} and {scene.sample_rate} Hz cost about "
            f"{scene.per_second / settings.work_per_second:.2f} s per second of audio); the "
            f"server renders at most {settings.max_render_s:g} s per request (GUITAR_MAX_RENDER_S):"
            f" at these settings the duration must be at most {most:.2f} s, or lower the quality, "
            "the sample rate or the strings played", scene.duration,
            {"le": round(most, 3), "estimated_s": round(seconds, 1)})])
    return seconds


def check_streamable(scene: engine.Scene) -> None:
    """A stream is a WAV file: its header goes out before the first sample exists."""
    if scene.output.format != "wav":
        raise RequestValidationError([_error(
            "output.format", "literal_error",
            f"/render/stream sends WAV only; got {scene.output.format!r} "
            "(use POST /render for flac or ogg)", scene.output.format,
            {"expected": "'wav'"})])
    if scene.output.stems:
        raise RequestValidationError([_error(
            "output.stems", "literal_error",
            "/render/stream sends the mix only; stems come from POST /render (a zip) or a job "
            "(GET /jobs/{id}/stems)", True, {"expected": "false"})])
