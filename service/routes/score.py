"""Scores in over HTTP: ``POST /score/scene`` (a Guitar Pro, MusicXML or MIDI upload -> the scene JSON),
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

from pathlib import PurePath
from typing import Annotated, Any

from fastapi import APIRouter, Body, File, Form, Request, Response, UploadFile
from fastapi.exceptions import RequestValidationError

import engine

from .. import audio
from ..responses import (
    ERROR_RESPONSES,
    realtime_factor,
    scene_payload,
    seconds,
    warnings_header,
    while_connected,
)
from ..score_form import (
    form_error,
    importer_options,
    parse_options,
    parse_output,
    prepare_score,
    read_upload,
)
from ..validation import StrictJSONRoute, check_limits

router = APIRouter(tags=["scores"])
labels_router = APIRouter(route_class=StrictJSONRoute, tags=["scores"])

_FORM_DOC = ("multipart/form-data: `file` (a .gp3/.gp4/.gp5/.gpx/.gp/.musicxml/.xml/.mxl/.mid/"
             ".midi file), optional `options` (JSON: tracks, presets, tempo_scale, max_seconds, "
             "sample_rate, all_instruments, quality, model)")


@router.post(
    "/score/scene",
    description="A Guitar Pro, MusicXML or MIDI file as a scene: to read, edit, or send to "
                "`POST /render`. " + _FORM_DOC,
    responses={
        200: {"description": "the scene (JSON) the score becomes; X-Score-Warnings: a JSON array "
                             "of what could not be played (absent when nothing); "
                             "X-Score-Warnings-Summary: the same, one line per message and "
                             "track with its bars"},
        **{k: v for k, v in ERROR_RESPONSES.items() if k != 502},
    },
)
async def score_scene(
    request: Request,
    file: Annotated[UploadFile, File(description="a score file (Guitar Pro, MusicXML or MIDI)")],
    options: Annotated[str | None, Form(description="JSON object of options")] = None,
) -> Response:
    opts = parse_options(options)
    data, name = await read_upload(file)
    # what goes out is a scene /render accepts (up to its limits)
    ready = await prepare_score(request, data, name, opts, importer_options(opts))
    return Response(ready.raw, media_type="application/json",
                    headers=_score_warnings(ready.warnings))


@router.post(
    "/score/labels",
    description="The note labels of a score file as it plays (JAMS, as from `POST /scene/labels` "
                "for the scene `POST /score/scene` gives), from the score itself: a whole song's "
                "scene can be larger than a request body may be. " + _FORM_DOC,
    responses={
        200: {"description": "JAMS (JSON), as from POST /scene/labels; X-Score-Warnings and "
                             "X-Score-Warnings-Summary as for POST /score/scene",
              "content": {"application/json": {}}},
        **{k: v for k, v in ERROR_RESPONSES.items() if k != 502},
    },
)
async def score_labels(
    request: Request,
    file: Annotated[UploadFile, File(description="a score file (Guitar Pro, MusicXML or MIDI)")],
    options: Annotated[str | None, Form(description="JSON object of options")] = None,
) -> Response:
    settings, pool = request.state.settings, request.state.pool
    opts = parse_options(options)
    data, name = await read_upload(file)
    ready = await prepare_score(request, data, name, opts, importer_options(opts))
    f = ready.figures
    _check_label_limits(f.duration, f.events, f.tracks, settings)
    raw, _ = await pool.call("labels", {"scene": ready.raw},
                             _labels_time_limit(ready.figures.duration, settings))
    return Response(raw, media_type="application/json",
                    headers=_score_warnings(ready.warnings))


@router.post(
    "/render/score",
    description="Render a Guitar Pro, MusicXML or MIDI file, like `POST /render` renders a "
                "scene. The score may play at most the service's `max_duration_s` (`GET /limits`): "
                "`options.max_seconds` renders the beginning of a longer one. " + _FORM_DOC
                + ", `output` (the scene's output object as JSON, or a format name)",
    response_class=Response,
    responses={
        200: {"description": "the audio file, as from POST /render (same headers), with "
                             "X-Score-Warnings as for POST /score/scene",
              "content": {t: {} for t in audio.MEDIA_TYPES.values()}},
        **ERROR_RESPONSES,
    },
)
async def render_score(
    request: Request,
    file: Annotated[UploadFile, File(description="a score file (Guitar Pro, MusicXML or MIDI)")],
    options: Annotated[str | None, Form(description="JSON object of options")] = None,
    output: Annotated[str | None, Form(description="the scene's output object as JSON, or "
                                                   "a format name: wav, flac, ogg")] = None,
) -> Response:
    settings, pool = request.state.settings, request.state.pool
    opts = parse_options(options)
    out_fields = parse_output(output)
    data, name = await read_upload(file)
    limit = settings.max_duration_s
    importer = importer_options(opts)
    # Never import more than the service may render: a score longer than the limit is cut just
    # past it and then refused below, unless the client asked for its beginning.
    asked = importer.get("max_seconds")
    if asked is not None and asked > limit:
        raise form_error("options.max_seconds", f"Input should be less than or equal to "
                          f"{limit:g} (service limit GUITAR_MAX_DURATION_S)", "less_than_equal",
                          asked)
    importer["max_seconds"] = asked if asked is not None else limit + 0.5
    ready = await prepare_score(request, data, name, opts, importer, out_fields,
                                settings.max_score_events, "GUITAR_MAX_SCORE_EVENTS")
    sc = ready.figures
    if sc.duration > limit:
        raise form_error("options.max_seconds",
                          f"the score plays longer than this service's limit of {limit:g} s "
                          "(GUITAR_MAX_DURATION_S); give options.max_seconds to render its "
                          "beginning", "less_than_equal", asked)
    # admitted by its estimated cost as /render is: a heavy score takes a heavy slot, and its
    # time limit follows the estimate; a client gone withdraws it (a heavy one running stops)
    try:
        estimated_s = check_limits(sc, settings, max_events=settings.max_score_events)
    except RequestValidationError as exc:
        raise _as_score_option(exc) from None
    out = await while_connected(request, pool.render(
        {"scene": ready.raw, "diagnostics": sc.diagnostics, "sample_rate": sc.sample_rate,
         "format": sc.format, "subtype": sc.subtype, "channels": sc.channels,
         "name": _ascii(PurePath(name).stem or "score")},
        settings.time_limit_s(sc.duration, estimated_s),
        heavy=estimated_s > settings.heavy_render_s, cost=estimated_s), settings.disconnect_poll_s)
    audio_s = out.frames / sc.sample_rate
    request.state.render_seconds, request.state.audio_seconds = out.render_seconds, audio_s
    stem = PurePath(name).stem or "score"
    headers = {
        "X-Render-Seconds": seconds(out.render_seconds),
        "X-Realtime-Factor": realtime_factor(audio_s, out.render_seconds),
        "Content-Disposition": 'inline; filename="'
                               f'{_ascii(stem)}.{"zip" if sc.stems else sc.format}"',
        **warnings_header(out.warnings),
        **_score_warnings(ready.warnings),
    }
    if out.energy_error is not None:
        headers["X-Energy-Error"] = repr(out.energy_error)
    return Response(out.data, media_type=audio.media_type(sc.format, sc.stems),
                    headers=headers)


def _as_score_option(exc: RequestValidationError) -> RequestValidationError:
    """A score's scene over the cost budget was refused at ``duration``, a field its client never
    sent: its way out is ``options.max_seconds`` (the longest that fits is the same number)."""
    errors = []
    for e in exc.errors():
        if e.get("type") == "render_cost":
            e = {**e, "loc": ("body", "options", "max_seconds"),
                 "msg": e["msg"].replace("the duration must be", "options.max_seconds must be")}
        errors.append(e)
    return RequestValidationError(errors)


def _score_warnings(warnings: list[str]) -> dict[str, str]:
    """``X-Score-Warnings``: what the score asks for that the scene cannot play (each naming bar,
    beat, track and effect), as a JSON array, shaped as ``X-Render-Warnings``.
    ``X-Score-Warnings-Summary``: the same grouped (``engine.score.warnings``: "track 'Lead' (1):
    fade-in (volume swell) not playable, ignored: bars 9–12 (8 beats)")."""
    if not warnings:
        return {}
    return {**warnings_header(warnings, "X-Score-Warnings"),
            **warnings_header(engine.group_warnings(warnings), "X-Score-Warnings-Summary")}


def _ascii(text: str) -> str:
    safe = "".join(c if c.isascii() and (c.isalnum() or c in "-_.") else "_" for c in text)
    return safe[:80] or "score"


@labels_router.post(
    "/scene/labels",
    responses={
        200: {"description": "JAMS (JSON) in GuitarSet's layout: one note_midi and one "
                             "pitch_contour annotation per string of each track (each note's "
                             "fret and articulations in the note_midi sandbox.notes); beat, "
                             "tempo, key_mode and chord from the scene's score",
              "content": {"application/json": {}}},
        **{k: v for k, v in ERROR_RESPONSES.items() if k != 502},
    },
)
async def scene_labels(scene: Annotated[engine.Scene, Body()], request: Request) -> Response:
    """The note labels of a scene (for example one from `POST /score/scene`): which note sounds on
    which string and fret, when, as JAMS (`jams.load` reads it)."""
    settings, pool = request.state.settings, request.state.pool
    _check_label_limits(scene.duration, scene.event_count(), scene.tracks is not None, settings)
    raw, _ = await pool.call("labels", {"scene": scene_payload(scene)},
                             _labels_time_limit(scene.duration, settings))
    return Response(raw, media_type="application/json")



def _labels_time_limit(duration: float, settings: Any) -> float:
    """Labels take time in proportion to the song (their pitch contours have a frame every
    10 ms per string): a whole song gets a render's wall-time budget for its length, not the
    fixed budget of a score import, which a whole song's labels outran."""
    return max(settings.score_import_time_limit_s, settings.time_limit_s(duration))


def _check_label_limits(duration: float, events: int, tracks: bool, settings: Any) -> None:
    """Labelling renders no audio, so a scene as long and as large as a job may render is labelled
    (the demo page shows the tab of a whole song before and while it renders as a job).
    ``events``: over all tracks; ``tracks``: a scene of tracks (where the count is reported)."""
    if duration > settings.job_max_duration_s:
        raise form_error("duration", f"Input should be less than or equal to "
                         f"{settings.job_max_duration_s:g} (service limit "
                         "GUITAR_JOB_MAX_DURATION_S)", "less_than_equal", duration)
    if events > settings.job_max_events:
        raise form_error("tracks" if tracks else "events",
                         f"List should have at most {settings.job_max_events} items (service "
                         f"limit GUITAR_JOB_MAX_EVENTS, counted over all tracks), not "
                         f"{events}", "too_long", events)
