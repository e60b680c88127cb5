"""Scores in over HTTP: ``POST /score/scene`` (a Guitar Pro or MIDI upload -> the scene JSON),
``POST /render/score`` (the same upload -> audio, like ``/render``) and ``POST /scene/labels`` (a
scene -> its note labels as JAMS JSON).

An uploaded file is never parsed in the API process: a worker imports it (``service.worker``,
job ``score``) under the admission and deadline of any render, so a hostile file (a Guitar Pro file
claiming 10^9 measures, a zip renamed .gp5, a truncated file) costs a worker at most
``GUITAR_SCORE_IMPORT_TIME_LIMIT_S`` and is answered 422 with the importer's one-line reason (or
504 if it ran out of time; the worker is then replaced).  The upload itself is bounded by
``GUITAR_MAX_BODY_BYTES`` like every body.
"""

from __future__ import annotations

import json
import re
from pathlib import PurePath
from typing import Annotated, Any

from fastapi import APIRouter, Body, File, Form, Request, Response, UploadFile
from fastapi.exceptions import RequestValidationError
from pydantic import BaseModel, ConfigDict, Field, ValidationError

import engine
from engine.scene import MAX_EVENTS, SAMPLE_RATE_MAX, SAMPLE_RATE_MIN

from .. import audio
from ..pool import RenderFailed, RenderTimeout
from ..validation import StrictJSONRoute, check_limits
from .render import (
    _ERRORS,
    _realtime_factor,
    _seconds,
    _warnings,
    _while_connected,
    scene_payload,
)

router = APIRouter(tags=["scores"])
labels_router = APIRouter(route_class=StrictJSONRoute, tags=["scores"])

SCORE_SUFFIXES = (".gp3", ".gp4", ".gp5", ".mid", ".midi")
_OPTION_IN_MESSAGE = re.compile(r"^(options\.[a-z_]+): (.*)$", re.S)


class ScoreOptions(BaseModel):
    """The form field ``options`` (JSON): how the score becomes a scene
    (``engine.score_to_scene``'s options) and the scene's quality and model."""

    model_config = ConfigDict(extra="forbid")

    tracks: list[int | str] | None = Field(
        None, min_length=1, max_length=64,
        description="the tracks to play, by number as the score numbers them (from 1) or by name; "
                    "default every pitched track")
    presets: str | dict[str, str] | None = Field(
        None, description="one preset for every track, or {track number or name: preset}")
    tempo_scale: float | None = Field(None, ge=0.05, le=20.0,
                                      description="multiplies the tempo (2: twice as fast)")
    max_seconds: float | None = Field(None, gt=0.0, description="keep only the first seconds")
    sample_rate: int | None = Field(None, ge=SAMPLE_RATE_MIN, le=SAMPLE_RATE_MAX,
                                    description="the scene's sample rate (default 44100)")
    quality: engine.QualityName | None = Field(
        None, description="the scene's quality (default standard)")
    model: engine.ModelName | None = Field(
        None, description="the scene's string model (default fdtd; waveguide: many times cheaper)")


def _form_error(field: str, msg: str, kind: str = "value_error", value: Any = None) -> Any:
    return RequestValidationError([{"type": kind, "loc": ("body", *field.split(".")), "msg": msg,
                                    "input": value}])


def _options(text: str | None) -> ScoreOptions:
    if not text:
        return ScoreOptions()
    try:
        data = json.loads(text, parse_constant=_refuse_constant)
    except ValueError as exc:
        raise _form_error("options", f"not valid JSON: {exc}") from None
    if not isinstance(data, dict):
        raise _form_error("options", f"a JSON object, not {type(data).__name__}", "dict_type")
    try:
        return ScoreOptions.model_validate(data)
    except ValidationError as exc:
        raise RequestValidationError([
            {**e, "loc": ("body", "options", *e["loc"])} for e in exc.errors(include_url=False)
        ]) from None


def _refuse_constant(token: str) -> Any:
    raise ValueError(f"{token} is not a number JSON allows")


def _output(text: str | None) -> dict[str, Any]:
    """The form field ``output``: the scene's ``output`` object as JSON (``{"format": "flac",
    "channels": 2}``), or just a format name (``flac``)."""
    if not text:
        return {}
    if text.strip() in audio.MEDIA_TYPES:
        return {"format": text.strip()}
    try:
        data = json.loads(text, parse_constant=_refuse_constant)
    except ValueError as exc:
        raise _form_error("output", f"a format name (wav, flac, ogg) or the scene's output object "
                                    f"as JSON: {exc}") from None
    if not isinstance(data, dict):
        raise _form_error("output", f"a JSON object, not {type(data).__name__}", "dict_type")
    return data


async def _upload(file: UploadFile) -> tuple[bytes, str]:
    name = PurePath(file.filename or "").name
    suffix = PurePath(name).suffix.lower()
    if name and suffix not in SCORE_SUFFIXES:
        raise _form_error("file", f"{name!r}: unknown type {suffix or '(no suffix)'!r}; a score "
                                  "is .gp3, .gp4, .gp5, .mid or .midi", value=name)
    data = await file.read()
    if not data:
        raise _form_error("file", f"{name or 'the upload'} is empty (0 bytes)", value=name)
    return data, name


async def _import(request: Request, data: bytes, name: str, options: dict[str, Any],
                  max_events: int = MAX_EVENTS, max_events_setting: str = "the engine's limit"
                  ) -> tuple[dict[str, Any], list[str]]:
    """The scene a score becomes and the importer's warnings, from a worker.  A scene of more
    than ``max_events`` events is refused by the worker in one line (``max_events_setting``
    names the limit), so this process never parses or echoes a scene of megabytes."""
    settings, pool = request.state.settings, request.state.pool
    try:
        raw, meta = await _while_connected(request, pool.call(
            "score", {"data": data, "filename": name, "options": options,
                      "max_events": max_events, "max_events_setting": max_events_setting},
            settings.score_import_time_limit_s), settings.disconnect_poll_s)
    except RenderTimeout:
        raise RenderTimeout(f"importing the score took longer than its time limit of "
                            f"{settings.score_import_time_limit_s:g} s "
                            "(GUITAR_SCORE_IMPORT_TIME_LIMIT_S) and was stopped") from None
    except RenderFailed as exc:
        if exc.kind != "invalid":
            raise
        # The importer's one line names an option (``options.presets: ...``) or the file.
        m = _OPTION_IN_MESSAGE.match(exc.message)
        field, msg = (m.group(1), m.group(2)) if m else ("file", exc.message)
        if field == "file" and name and name not in msg:
            msg = f"{name}: {msg}"
        raise _form_error(field, msg, "score_invalid") from None
    return json.loads(raw), list(meta["warnings"])


def _score_warnings(warnings: list[str]) -> dict[str, str]:
    """``X-Score-Warnings``: what the score asks for that the scene cannot play (each naming bar,
    beat, track and effect), as a JSON array; the first ``render.MAX_HEADER_WARNINGS`` and a
    count of the rest."""
    header = _warnings(warnings).get("X-Render-Warnings")
    return {"X-Score-Warnings": header} if header else {}


def _importer_options(opts: ScoreOptions) -> dict[str, Any]:
    return opts.model_dump(exclude_none=True, exclude={"quality", "model"})


def apply_scene_options(scene: dict[str, Any], opts: ScoreOptions) -> None:
    """The options that are the scene's own fields, not the importer's."""
    if opts.quality is not None:
        scene["quality"] = opts.quality
    if opts.model is not None:
        scene["model"] = opts.model


_FORM_DOC = ("multipart/form-data: `file` (a .gp3/.gp4/.gp5/.mid/.midi file), optional `options` "
             "(JSON: tracks, presets, tempo_scale, max_seconds, sample_rate, quality, model)")


@router.post(
    "/score/scene",
    description="A Guitar Pro or MIDI file as a scene: to read, edit, or send to `POST /render`. "
                + _FORM_DOC,
    responses={
        200: {"description": "the scene (JSON) the score becomes; X-Score-Warnings: a JSON array "
                             "of what could not be played (absent when nothing)"},
        **{k: v for k, v in _ERRORS.items() if k != 502},
    },
)
async def score_scene(
    request: Request,
    file: Annotated[UploadFile, File(description="Guitar Pro 3/4/5 or Standard MIDI file")],
    options: Annotated[str | None, Form(description="JSON object of options")] = None,
) -> Response:
    opts = _options(options)
    data, name = await _upload(file)
    scene, warnings = await _import(request, data, name, _importer_options(opts))
    apply_scene_options(scene, opts)
    _validate(scene)  # what goes out is a scene /render accepts (up to its limits)
    return Response(json.dumps(scene), media_type="application/json",
                    headers=_score_warnings(warnings))


@router.post(
    "/render/score",
    description="Render a Guitar Pro or MIDI file, like `POST /render` renders a scene. The score "
                "may play at most the service's `max_duration_s` (`GET /limits`): "
                "`options.max_seconds` renders the beginning of a longer one. " + _FORM_DOC
                + ", `output` (the scene's output object as JSON, or a format name)",
    response_class=Response,
    responses={
        200: {"description": "the audio file, as from POST /render (same headers), with "
                             "X-Score-Warnings as for POST /score/scene",
              "content": {t: {} for t in audio.MEDIA_TYPES.values()}},
        **_ERRORS,
    },
)
async def render_score(
    request: Request,
    file: Annotated[UploadFile, File(description="Guitar Pro 3/4/5 or Standard MIDI file")],
    options: Annotated[str | None, Form(description="JSON object of options")] = None,
    output: Annotated[str | None, Form(description="the scene's output object as JSON, or "
                                                   "a format name: wav, flac, ogg")] = None,
) -> Response:
    settings, pool = request.state.settings, request.state.pool
    opts = _options(options)
    out_fields = _output(output)
    data, name = await _upload(file)
    limit = settings.max_duration_s
    importer = _importer_options(opts)
    # Never import more than the service may render: a score longer than the limit is cut just
    # past it and then refused below, unless the client asked for its beginning.
    asked = importer.get("max_seconds")
    if asked is not None and asked > limit:
        raise _form_error("options.max_seconds", f"Input should be less than or equal to "
                          f"{limit:g} (service limit GUITAR_MAX_DURATION_S)", "less_than_equal",
                          asked)
    importer["max_seconds"] = asked if asked is not None else limit + 0.5
    scene, warnings = await _import(request, data, name, importer, settings.max_score_events,
                                    "GUITAR_MAX_SCORE_EVENTS")
    if scene["duration"] > limit:
        raise _form_error("options.max_seconds",
                          f"the score plays longer than this service's limit of {limit:g} s "
                          "(GUITAR_MAX_DURATION_S); give options.max_seconds to render its "
                          "beginning", "less_than_equal", asked)
    apply_scene_options(scene, opts)
    scene["output"] = {**scene.get("output", {}), **out_fields}
    sc = _validate(scene)
    # admitted by its estimated cost as /render is: a heavy score takes a heavy slot, and its
    # time limit follows the estimate; a client gone withdraws it (a heavy one running stops)
    estimated_s = check_limits(sc, settings, max_events=settings.max_score_events)
    out = await _while_connected(request, pool.render(
        {"scene": scene_payload(sc), "diagnostics": sc.diagnostics,
         "sample_rate": sc.sample_rate, "format": sc.output.format,
         "subtype": sc.output.subtype, "channels": sc.output.channels},
        settings.time_limit_s(sc.duration, estimated_s),
        heavy=estimated_s > settings.heavy_render_s), settings.disconnect_poll_s)
    audio_s = out.frames / sc.sample_rate
    request.state.render_seconds, request.state.audio_seconds = out.render_seconds, audio_s
    stem = PurePath(name).stem or "score"
    headers = {
        "X-Render-Seconds": _seconds(out.render_seconds),
        "X-Realtime-Factor": _realtime_factor(audio_s, out.render_seconds),
        "Content-Disposition": f'inline; filename="{_ascii(stem)}.{sc.output.format}"',
        **_warnings(out.warnings),
        **_score_warnings(warnings),
    }
    if out.energy_error is not None:
        headers["X-Energy-Error"] = repr(out.energy_error)
    return Response(out.data, media_type=audio.MEDIA_TYPES[sc.output.format], headers=headers)


def _validate(scene: dict[str, Any]) -> engine.Scene:
    try:
        return engine.Scene.model_validate(scene)
    except ValidationError as exc:
        raise RequestValidationError([
            {**e, "loc": ("body", *_scene_loc(e["loc"]))} for e in exc.errors(include_url=False)
        ]) from None


def _scene_loc(loc: tuple) -> tuple:
    """Where an invalid field of the converted scene came from: ``output.*``, ``quality``,
    ``model`` and ``sample_rate`` are the client's own fields; anything else the score's."""
    if loc and loc[0] == "output":
        return ("output", *loc[1:])
    if loc and loc[0] in ("quality", "model", "sample_rate"):
        return ("options", *loc)
    return ("file", *map(str, loc))


def _ascii(text: str) -> str:
    safe = "".join(c if c.isascii() and (c.isalnum() or c in "-_.") else "_" for c in text)
    return safe[:80] or "score"


@labels_router.post(
    "/scene/labels",
    responses={
        200: {"description": "JAMS (JSON) in GuitarSet's layout: one note_midi annotation per "
                             "string of each track; each note's track, string, fret and "
                             "articulations in the annotation's sandbox.notes",
              "content": {"application/json": {}}},
        **{k: v for k, v in _ERRORS.items() if k != 502},
    },
)
async def scene_labels(scene: Annotated[engine.Scene, Body()], request: Request) -> Response:
    """The note labels of a scene (for example one from `POST /score/scene`): which note sounds on
    which string and fret, when, as JAMS (`jams.load` reads it)."""
    settings, pool = request.state.settings, request.state.pool
    check_limits(scene, settings, max_events=settings.max_score_events)
    raw, _ = await pool.call("labels", {"scene": scene_payload(scene)},
                             settings.score_import_time_limit_s)
    return Response(raw, media_type="application/json")

