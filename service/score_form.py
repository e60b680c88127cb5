"""A score upload as a multipart form, read alike by ``POST /score/scene``, ``POST /render/score``
and ``POST /jobs``: the fields ``file``, ``options`` and ``output``, the import in a worker, and the
scene it becomes, each error a 422 naming the form field it came from."""

from __future__ import annotations

import json
import re
from dataclasses import dataclass
from pathlib import PurePath
from typing import Any

from fastapi import Request, UploadFile
from fastapi.exceptions import RequestValidationError
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator

import engine
from engine.scene import MAX_EVENTS, SAMPLE_RATE_MAX, SAMPLE_RATE_MIN

from . import audio
from .exceptions import RenderFailed, RenderTimeout
from .responses import while_connected
from .validation import Figures

SCORE_SUFFIXES = engine.SCORE_SUFFIXES  # every score format the engine reads
_OPTION_IN_MESSAGE = re.compile(r"^(options\.[a-z_]+): (.*)$", re.S)


class ScoreOptions(BaseModel):
    """The form field ``options`` (JSON): how the score becomes a scene
    (``engine.score_to_scene``'s options) and the scene's quality and model."""

    model_config = ConfigDict(extra="forbid")

    tracks: list[int | str] | None = Field(
        None, min_length=1, max_length=64,
        description="the tracks to play, by number as the score numbers them (from 1) or by name; "
                    "default every guitar and bass track")
    all_instruments: bool | None = Field(
        None, description="true: play every pitched track (piano, voice, strings ...) on a guitar "
                          "too; by default other instruments are skipped and named in the warnings")
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

    @field_validator("presets")
    @classmethod
    def _short_names(cls, v: str | dict[str, str] | None) -> str | dict[str, str] | None:
        # an unknown name is quoted in the importer's refusal: bounded, so is the refusal
        names = [v] if isinstance(v, str) else [*v.keys(), *v.values()] if v else []
        if len(names) > 2 * 64 or any(len(n) > 200 for n in names):
            raise ValueError("at most 64 tracks, each name at most 200 characters")
        return v


def form_error(field: str, msg: str, kind: str = "value_error", value: Any = None) -> Any:
    return RequestValidationError([{"type": kind, "loc": ("body", *field.split(".")), "msg": msg,
                                    "input": value}])


def parse_options(text: str | None) -> ScoreOptions:
    if not text:
        return ScoreOptions()
    try:
        data = json.loads(text, parse_constant=_refuse_constant)
    except ValueError as exc:
        raise form_error("options", f"not valid JSON: {exc}") from None
    if not isinstance(data, dict):
        raise form_error("options", f"a JSON object, not {type(data).__name__}", "dict_type")
    try:
        return ScoreOptions.model_validate(data)
    except ValidationError as exc:
        raise RequestValidationError([
            {**e, "loc": ("body", "options", *e["loc"])} for e in exc.errors(include_url=False)
        ]) from None


def _refuse_constant(token: str) -> Any:
    raise ValueError(f"{token} is not a number JSON allows")


def parse_output(text: str | None) -> dict[str, Any]:
    """The form field ``output``: the scene's ``output`` object as JSON (``{"format": "flac",
    "channels": 2}``), or just a format name (``flac``)."""
    if not text:
        return {}
    if text.strip() in audio.MEDIA_TYPES:
        return {"format": text.strip()}
    try:
        data = json.loads(text, parse_constant=_refuse_constant)
    except ValueError as exc:
        raise form_error("output", f"a format name (wav, flac, ogg) or the scene's output object "
                                    f"as JSON: {exc}") from None
    if not isinstance(data, dict):
        raise form_error("output", f"a JSON object, not {type(data).__name__}", "dict_type")
    return data


async def read_upload(file: UploadFile) -> tuple[bytes, str]:
    name = PurePath(file.filename or "").name
    suffix = PurePath(name).suffix.lower()
    if name and suffix not in SCORE_SUFFIXES:
        raise form_error("file", f"{name!r}: unknown type {suffix or '(no suffix)'!r}; a score "
                                  f"is one of {', '.join(SCORE_SUFFIXES)}", value=name)
    data = await file.read()
    if not data:
        raise form_error("file", f"{name or 'the upload'} is empty (0 bytes)", value=name)
    return data, name


@dataclass(frozen=True)
class Prepared:
    """A score's scene as a worker made it ready: its JSON (the client's options and output
    fields set, valid), the importer's warnings and the figures the limits read."""

    raw: bytes
    warnings: list[str]
    figures: Figures


async def prepare_score(request: Request, data: bytes, name: str, opts: ScoreOptions,
                        importer: dict[str, Any], output: dict[str, Any] | None = None,
                        max_events: int = MAX_EVENTS,
                        max_events_setting: str = "the engine's limit") -> Prepared:
    """The scene a score becomes, from a worker: imported (``importer``: the importer's options),
    the scene's own options (``opts.quality``, ``opts.model``) and ``output`` fields set,
    validated and measured there; this process never parses a whole song's scene.  A scene of
    more than ``max_events`` events is refused by the worker in one line (``max_events_setting``
    names the limit); a client gone withdraws the work.  The same file with the same importer
    options is imported once (``service.score_cache``): the worker then starts from the import
    kept here."""
    settings, pool = request.state.settings, request.state.pool
    cache = request.state.scores
    key = cache.key(data, name, importer)
    kept = cache.get(key, importer, max_events)
    prepare = {"quality": opts.quality, "model": opts.model, "output": output or {}}
    job: dict[str, Any] = {"filename": name, "options": importer, "max_events": max_events,
                           "max_events_setting": max_events_setting, "prepare": prepare}
    if kept is not None:
        job["imported"] = kept.raw
    else:
        job["data"] = data
    try:
        raw, meta = await while_connected(request, pool.call(
            "score", job, settings.score_import_time_limit_s), settings.disconnect_poll_s)
    except RenderTimeout:
        raise RenderTimeout(f"importing the score took longer than its time limit of "
                            f"{settings.score_import_time_limit_s:g} s "
                            "(GUITAR_SCORE_IMPORT_TIME_LIMIT_S) and was stopped") from None
    except RenderFailed as exc:
        if exc.kind == "fields":
            raise RequestValidationError([
                e if e.get("type") == "too_many_errors"
                else {**e, "loc": ("body", *_scene_loc(tuple(e["loc"])))}
                for e in json.loads(exc.message)]) from None
        if exc.kind != "invalid":
            raise
        # The importer's one line names an option (``options.presets: ...``) or the file.
        m = _OPTION_IN_MESSAGE.match(exc.message)
        field, msg = (m.group(1), m.group(2)) if m else ("file", exc.message)
        if field == "file" and name and name not in msg:
            msg = f"{name}: {msg}"
        raise form_error(field, msg, "score_invalid") from None
    if kept is None:
        cache.put(key, importer, meta["imported"], meta)
    warnings = list(kept.warnings) if kept is not None else list(meta["warnings"])
    return Prepared(raw, warnings, Figures(**meta["figures"]))


def importer_options(opts: ScoreOptions) -> dict[str, Any]:
    return opts.model_dump(exclude_none=True, exclude={"quality", "model"})


def _scene_loc(loc: tuple) -> tuple:
    """Where an invalid field of the converted scene came from: ``output.*``, ``quality``,
    ``model`` and ``sample_rate`` are the client's own fields; anything else the score's."""
    if loc and loc[0] == "output":
        return ("output", *loc[1:])
    if loc and loc[0] in ("quality", "model", "sample_rate"):
        return ("options", *loc)
    return ("file", *map(str, loc))
