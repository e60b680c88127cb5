"""POST /jobs, GET /jobs/{id}, GET /jobs/{id}/audio, /stream, /labels and /stems, DELETE /jobs/{id}.

A job is a render that outlives its request: the scene (JSON, or a score uploaded as a multipart
form) is checked and stored at once (202 with a ``Location``), rendered by ``JobRunner`` when a
worker is free, and its results kept until ``GUITAR_JOB_RETENTION_S`` has passed.
"""

from __future__ import annotations

import asyncio
import json
import re
from collections.abc import AsyncIterator
from typing import Any

from fastapi import APIRouter, Request, Response
from fastapi.exceptions import RequestValidationError
from fastapi.responses import FileResponse, JSONResponse, StreamingResponse
from pydantic import BaseModel, Field, ValidationError

import engine

from .. import audio
from ..clients import client_id
from ..responses import scene_payload
from ..score_form import (
    importer_options,
    parse_options,
    parse_output,
    prepare_score,
    read_upload,
)
from ..validation import Figures, reject_nonfinite_json

router = APIRouter(tags=["jobs"])


class Job(BaseModel):
    id: str
    status: str = Field(description="queued, running, done, failed or cancelled")
    progress: float = Field(description="share of the audio rendered, 0..1")
    error: str | None = Field(None, description="why the job failed")
    created: float = Field(description="Unix time")
    started: float | None = None
    finished: float | None = None
    attempts: int = Field(description="runs started (a restart or a dead worker re-runs a job)")
    duration: float = Field(description="seconds of audio asked for")
    format: str
    audio_seconds: float | None = None
    render_seconds: float | None = Field(None, description="wall time of the run that finished")
    warnings: list[str] = Field(default_factory=list)
    labels: bool = Field(description="whether GET /jobs/{id}/labels has a JAMS file")
    labels_error: str | None = None
    audio_url: str
    labels_url: str
    stems_url: str | None = Field(None, description="with output.stems: a zip of each "
                                                    "string's file (docs/service.md)")


def _public(job: dict[str, Any]) -> dict[str, Any]:
    out = {k: job[k] for k in Job.model_fields if k in job}
    out["warnings"] = json.loads(job["warnings"])
    out["labels"] = bool(job["labels"])
    out["audio_url"] = f"/jobs/{job['id']}/audio"
    out["labels_url"] = f"/jobs/{job['id']}/labels"
    if _wants_stems(job):
        out["stems_url"] = f"/jobs/{job['id']}/stems"
    return Job(**out).model_dump()


def _wants_stems(job: dict[str, Any]) -> bool:
    return bool(job.get("stems"))


def _errors_with_body(exc: ValidationError, prefix: tuple = ("body",)) -> RequestValidationError:
    errors = []
    for e in exc.errors():
        e = dict(e)
        e["loc"] = (*prefix, *e.get("loc", ()))
        errors.append(e)
    return RequestValidationError(errors)


def _field_error(field: str, kind: str, msg: str, value: Any) -> RequestValidationError:
    return RequestValidationError([{"type": kind, "loc": ("body", *field.split(".")),
                                    "msg": msg, "input": value}])


async def _scene_from_json(request: Request) -> tuple[str, Figures]:
    """The scene of a JSON body: the JSON the job keeps (only the fields the client set, as
    /render sends them: ``responses.scene_payload``) and its figures."""
    await reject_nonfinite_json(request)
    body = await request.body()
    try:
        scene = engine.Scene.model_validate_json(body)
    except ValidationError as exc:
        raise _errors_with_body(exc) from None
    return json.dumps(scene_payload(scene)), Figures.of(scene)


async def _scene_from_score(request: Request) -> tuple[str, Figures]:
    """A multipart form as ``POST /render/score`` takes (``file``, ``options``, ``output``), read
    by the same code: the score is imported, made ready and measured in a worker, never in this
    process."""
    s = request.state.settings
    form = await request.form()
    upload = form.get("file")
    if upload is None or isinstance(upload, str):
        raise _field_error("file", "missing", "file: the score file is required (a Guitar Pro "
                                              ".gp3/.gp4/.gp5 or MIDI .mid file)", None)
    text = {k: form.get(k) for k in ("options", "output")}
    if any(v is not None and not isinstance(v, str) for v in text.values()):
        raise _field_error("options", "string_type", "options and output are form fields of "
                                                     "JSON text, not files", None)
    opts = parse_options(text["options"])
    out_fields = parse_output(text["output"])
    data, name = await read_upload(upload)
    importer = importer_options(opts)
    asked = importer.get("max_seconds")
    if asked is not None and asked > s.job_max_duration_s:
        raise _field_error("options.max_seconds", "less_than_equal", f"options.max_seconds: at "
                           f"most {s.job_max_duration_s:g} s for a job (GUITAR_JOB_MAX_DURATION_S)",
                           asked)
    # never import more than a job may render: a longer score is cut just past the limit and
    # refused by the duration check, unless the client asked for its beginning
    importer["max_seconds"] = asked if asked is not None else s.job_max_duration_s + 0.5
    ready = await prepare_score(request, data, name, opts, importer, out_fields,
                                s.job_max_events, "GUITAR_JOB_MAX_EVENTS")
    return ready.raw.decode(), ready.figures


def _check_job_limits(scene: Figures, request: Request) -> float:
    """Raise a 422 for a scene outside the job limits; return its estimated render seconds."""
    s = request.state.settings
    if scene.duration > s.job_max_duration_s:
        raise _field_error("duration", "less_than_equal", f"duration: at most "
                           f"{s.job_max_duration_s:g} s for a job (GUITAR_JOB_MAX_DURATION_S)",
                           scene.duration)
    if scene.events > s.job_max_events:
        raise _field_error("events", "too_long", f"events: at most {s.job_max_events} for a job "
                           f"(GUITAR_JOB_MAX_EVENTS), not {scene.events}", scene.events)
    if not s.min_sample_rate <= scene.sample_rate <= s.max_sample_rate:
        raise _field_error("sample_rate", "range", f"sample_rate: between {s.min_sample_rate} and "
                           f"{s.max_sample_rate} Hz (GUITAR_MIN_SAMPLE_RATE, "
                           "GUITAR_MAX_SAMPLE_RATE)", scene.sample_rate)
    seconds = s.estimated_seconds(scene.work)
    if seconds > s.job_max_render_s:
        most = s.job_max_render_s * s.work_per_second / scene.per_second
        raise _field_error("duration", "render_cost", f"duration: this scene would take about "
                           f"{seconds:.0f} s to render; a job may take at most "
                           f"{s.job_max_render_s:g} s (GUITAR_JOB_MAX_RENDER_S): at these "
                           f"settings the duration must be at most {most:.2f} s, or lower the "
                           "quality, the sample rate or the strings played", scene.duration)
    return seconds


def _job_or_404(request: Request, job_id: str) -> dict[str, Any]:
    job = request.state.jobs.store.get(job_id)
    if job is None:
        raise _NotFound(f"no job {job_id!r} (unknown, or deleted after "
                        "GUITAR_JOB_RETENTION_S)")
    return job


class _NotFound(Exception):
    pass


class _NotReady(Exception):
    pass


def install(app: Any) -> None:
    async def not_found(request: Request, exc: Exception) -> JSONResponse:
        return JSONResponse({"detail": str(exc)}, status_code=404)

    async def not_ready(request: Request, exc: Exception) -> JSONResponse:
        return JSONResponse({"detail": str(exc)}, status_code=409)

    app.add_exception_handler(_NotFound, not_found)
    app.add_exception_handler(_NotReady, not_ready)


_SCENE_BODY = {"requestBody": {"required": True, "content": {
    "application/json": {"schema": {"$ref": "#/components/schemas/Scene"}},
    "multipart/form-data": {"schema": {"type": "object", "required": ["file"], "properties": {
        "file": {"type": "string", "format": "binary",
                 "description": "Guitar Pro 3/4/5 or MIDI file"},
        "options": {"type": "string", "description": "JSON: tracks, presets, tempo_scale, "
                                                     "max_seconds, sample_rate, quality"},
        "output": {"type": "string", "description": "JSON: the scene's output fields"}}}}}}}


@router.post("/jobs", status_code=202, response_model=Job, openapi_extra=_SCENE_BODY,
             responses={422: {"description": "invalid scene or score, or outside the job limits"},
                        429: {"description": "the client has GUITAR_JOB_MAX_PER_CLIENT jobs "
                                             "queued or running"},
                        503: {"description": f"{'GUITAR_MAX_JOBS'} jobs stored, none finished "
                                              "to make room"}})
async def create_job(request: Request) -> JSONResponse:
    """Queue a render: a scene as JSON, or a score as a multipart form (``file``, ``options``,
    ``output``, as ``POST /render/score``).  Answers 202 with the job and its ``Location``."""
    jobs = request.state.jobs
    if request.headers.get("content-type", "").startswith("multipart/form-data"):
        scene_json, scene = await _scene_from_score(request)
    else:
        scene_json, scene = await _scene_from_json(request)
    estimated_s = _check_job_limits(scene, request)
    s = request.state.settings
    client = client_id(request, s)
    if jobs.store.unfinished(client) >= s.job_max_per_client:
        return JSONResponse({"detail": f"this client has {s.job_max_per_client} jobs queued or "
                                       "running (GUITAR_JOB_MAX_PER_CLIENT); wait for some to "
                                       "finish, or cancel some (DELETE /jobs/{id})"},
                            status_code=429, headers={"Retry-After": "60"})
    if jobs.store.total() >= s.max_jobs:
        await asyncio.to_thread(jobs.cleanup)
        if jobs.store.total() >= s.max_jobs:
            return JSONResponse({"detail": f"{s.max_jobs} jobs are stored and none can be "
                                           "deleted yet (GUITAR_MAX_JOBS); try again later"},
                                status_code=503, headers={"Retry-After": "60"})
    job = jobs.store.create(scene_json, scene.format, scene.duration, cost=estimated_s,
                            client=client, stems=scene.stems)
    jobs.wake()
    return JSONResponse(_public(job), status_code=202, headers={"Location": f"/jobs/{job['id']}"})


@router.get("/jobs/{job_id}", response_model=Job, responses={404: {"description": "no such job"}})
async def get_job(job_id: str, request: Request) -> dict[str, Any]:
    """The job's status, progress (0..1) and, when it failed, the reason."""
    return _public(_job_or_404(request, job_id))


@router.get("/jobs/{job_id}/audio", response_class=FileResponse, responses={
    200: {"content": {t: {} for t in audio.MEDIA_TYPES.values()}},
    404: {"description": "no such job"}, 409: {"description": "the job is not done"}})
async def get_audio(job_id: str, request: Request) -> FileResponse:
    """The rendered audio, scaled and encoded as the scene's ``output`` asks (as ``/render``),
    once the job is done."""
    job = _job_or_404(request, job_id)
    if job["status"] != "done":
        raise _NotReady(f"job {job_id} is {job['status']}, not done"
                        + (f": {job['error']}" if job["error"] else ""))
    return FileResponse(request.state.jobs.store.audio_path(job),
                        media_type=audio.MEDIA_TYPES[job["format"]],
                        filename=f"{job_id}.{job['format']}")


# How often a stream waiting for the render to write more bytes looks at the file again.
STREAM_POLL_S = 0.1
_RANGE = re.compile(r"bytes=(\d*)-(\d*)$")


def _stream_layout(job: dict[str, Any]) -> tuple[int, str] | None:
    """(size of the WAV file the job writes as it renders, its subtype), or None when the job's
    file is rewritten at its end (normalized or converted: ``runner._finalize``)."""
    scene = json.loads(job["scene"])
    out = scene.get("output") or {}
    if job["format"] != "wav" or out.get("normalize", True):
        return None
    subtype, channels = out.get("subtype", "PCM_16"), out.get("channels", 1)
    frames = round(job["duration"] * scene.get("sample_rate", 44100))
    return audio.wav_size(frames, subtype, channels), subtype


@router.get("/jobs/{job_id}/stream", response_class=StreamingResponse, responses={
    200: {"content": {"audio/wav": {}}, "description": "the whole WAV file, as it is written"},
    206: {"description": "the bytes a Range header asks for, as they are written"},
    404: {"description": "no such job"},
    409: {"description": "the job's file is not written as it renders (normalized or not WAV), "
                         "or the job failed or was cancelled"},
    416: {"description": "a Range outside the file"}})
async def stream_audio(job_id: str, request: Request) -> Response:
    """The job's audio while it renders: a WAV of known length (``Content-Length``, ``Range``
    requests answered 206) whose bytes are sent as the render writes them, so that a player can
    start before the job is done and seek (a seek ahead of the render waits for it). Only for a
    job of ``output.format`` wav with ``output.normalize: false`` (its bytes, as ``GET
    /jobs/{id}/audio`` gives them when done, are those of ``POST /render/stream``)."""
    store = request.state.jobs.store
    job = _job_or_404(request, job_id)
    layout = await asyncio.to_thread(_stream_layout, job)  # a whole song's JSON: off the loop
    if layout is None:
        raise _NotReady(f"job {job_id} is not streamed: only a wav job with output.normalize "
                        "false is written as it renders; GET /jobs/{id}/audio once it is done")
    if job["status"] in ("failed", "cancelled"):
        raise _NotReady(f"job {job_id} is {job['status']}"
                        + (f": {job['error']}" if job["error"] else ""))
    total, _ = layout
    start, end = 0, total - 1
    asked = request.headers.get("range")
    m = _RANGE.match(asked.strip()) if asked else None
    if m and (m.group(1) or m.group(2)):
        if m.group(1):
            start = int(m.group(1))
            end = min(int(m.group(2)), total - 1) if m.group(2) else total - 1
        else:  # the last n bytes
            start = max(0, total - int(m.group(2)))
        if start > end:
            return Response(status_code=416, headers={"Content-Range": f"bytes */{total}"})
    folder = store.job_dir(job_id)
    part, final = folder / "stream.wav.part", store.audio_path(job)

    async def body() -> AsyncIterator[bytes]:
        f = None
        try:
            at = start
            while at <= end:
                if f is None:  # the render has not begun, or its file was just renamed
                    for path in (final, part):
                        try:
                            f = open(path, "rb")  # noqa: SIM115 - closed in finally
                            break
                        except FileNotFoundError:
                            continue
                if f is not None:
                    f.seek(at)
                    chunk = f.read(min(1 << 16, end + 1 - at))
                    if chunk:
                        at += len(chunk)
                        yield chunk
                        continue
                # nothing new: the render is behind, or over (then the file is whole or gone)
                now = store.get(job_id)
                if now is None or now["status"] in ("failed", "cancelled"):
                    return
                if now["status"] == "done" and f is not None and f.name == str(final):
                    return  # a file shorter than its header says: nothing more will come
                if now["status"] == "done" and f is not None:
                    f.close()
                    f = None  # renamed into place: read on from the final file
                    continue
                # (a client gone cancels this generator: Starlette listens for the disconnect)
                await asyncio.sleep(STREAM_POLL_S)
        finally:
            if f is not None:
                f.close()

    headers = {"Accept-Ranges": "bytes", "Content-Length": str(end + 1 - start),
               "Content-Disposition": f'inline; filename="{job_id}.wav"'}
    if m and (m.group(1) or m.group(2)):
        headers["Content-Range"] = f"bytes {start}-{end}/{total}"
        return StreamingResponse(body(), status_code=206, media_type="audio/wav",
                                 headers=headers)
    return StreamingResponse(body(), media_type="audio/wav", headers=headers)


@router.get("/jobs/{job_id}/labels", response_class=FileResponse, responses={
    200: {"content": {"application/json": {}}, "description": "JAMS, GuitarSet's layout"},
    404: {"description": "no such job, or no labels"}, 409: {"description": "not done"}})
async def get_labels(job_id: str, request: Request) -> FileResponse:
    """The scene's note labels as a JAMS file, once the job is done."""
    job = _job_or_404(request, job_id)
    if job["status"] != "done":
        raise _NotReady(f"job {job_id} is {job['status']}, not done")
    if not job["labels"]:
        raise _NotFound(f"job {job_id} has no labels: {job['labels_error']}")
    return FileResponse(request.state.jobs.store.labels_path(job_id),
                        media_type="application/json", filename=f"{job_id}.jams")


@router.get("/jobs/{job_id}/stems", response_class=FileResponse, responses={
    200: {"content": {"application/zip": {}},
          "description": "each string's file and stems.json, as POST /render's zip (without "
                         "the mix: GET /jobs/{id}/audio)"},
    404: {"description": "no such job, or no stems asked (output.stems)"},
    409: {"description": "not done"}})
async def get_stems(job_id: str, request: Request) -> FileResponse:
    """The stems of a job whose scene asked for them (``output.stems``), once it is done."""
    job = _job_or_404(request, job_id)
    if not _wants_stems(job):
        raise _NotFound(f"job {job_id} has no stems: its scene did not ask for them "
                        "(output.stems: true)")
    if job["status"] != "done":
        raise _NotReady(f"job {job_id} is {job['status']}, not done")
    return FileResponse(request.state.jobs.store.stems_path(job_id),
                        media_type="application/zip", filename=f"{job_id}-stems.zip")


@router.delete("/jobs/{job_id}", responses={
    200: {"model": Job, "description": "a queued or running job, now cancelled"},
    204: {"description": "a finished job, deleted with its results"},
    404: {"description": "no such job"}})
async def delete_job(job_id: str, request: Request) -> Response:
    """Cancel a queued or running job (200, the job now ``cancelled``); delete a finished one
    and its results (204)."""
    jobs = request.state.jobs
    before = jobs.store.cancel(job_id)
    if before is None:
        _job_or_404(request, job_id)
    if before in ("queued", "running"):
        jobs.cancel(job_id)
        return JSONResponse(_public(_job_or_404(request, job_id)))
    await asyncio.to_thread(jobs.store.delete, job_id)  # its folder: up to a song's files
    return Response(status_code=204)
