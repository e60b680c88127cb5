"""The render worker: the code that runs inside each worker process of ``service.pool``.

A worker owns one end of a duplex pipe.  It warms up (``engine.warmup()`` compiles or loads every
numba kernel, so no real render pays for that), says ``ready``, then serves one job at a time:

    parent -> worker   ("render", job_id, payload) | ("stream", job_id, payload)
                       (a payload's ``scene``: a dict, or its JSON as bytes)
                       | ("cancel", job_id) | None (stop)
    worker -> parent   ("beat", pid)                                  every heartbeat_s, always
                       ("warming", pid, what it is doing), before a long warm-up
                       ("ready", pid, warmup_seconds, frozen)          warmed up; ``frozen``:
                                                                      objects moved out of the
                                                                      garbage collector's sight
                       ("done", job_id, file_bytes, meta)             render finished
                       ("block", job_id, pcm_bytes, seconds_so_far, warnings)
                                                                      one streamed block
                       ("end", job_id, meta) | ("cancelled", job_id)  stream finished / stopped
                                                                      (a render: stopped)
                       ("error", job_id, kind, message)    kind: non_finite|invalid|internal|fields
    parent -> worker   ("score", job_id, {"data": bytes, "filename": str, "options": dict,
                                          "max_events": int | None, "max_events_setting": str,
                                          "imported": bytes | None, "prepare": dict})
    worker -> parent   ("done", job_id, scene_json_bytes, {"warnings": [...], "seconds": s,
                                                           "figures": dict, "imported": bytes})
                       ("error", job_id, "fields", errors_json)   the prepared scene is invalid
    parent -> worker   ("labels", job_id, {"scene": dict | json_bytes})
    a ``stream`` payload's ``subtype`` may be ``FLOAT64`` (raw float64 samples, for jobs) and
    ``raw`` true (the pickup velocity before any gain: a job normalizes it as /render does)
    and ``stems`` true (each block's stems as columns after the mix's: a job's stems)
    worker -> parent   ("done", job_id, jams_json_bytes, {"seconds": s})

Everything sent is plain data (bytes, floats, lists, dicts) so the parent never unpickles engine
objects.  ``warnings`` (``engine.RenderResult.warnings``: what may not sound as the player means it)
are worked out here, with the render, inside its time limit: in ``meta`` of ``done`` and ``end``,
and with the first streamed block (an empty list with the later ones).
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import signal
import tempfile
import threading
import time
from multiprocessing.connection import Connection
from typing import Any

import numpy as np

from . import audio, heap


class _Pipe:
    """The worker's end of the pipe, shared by the main thread and the heartbeat thread: one
    message at a time goes out."""

    def __init__(self, conn: Connection):
        self._conn = conn
        self._lock = threading.Lock()

    def send(self, msg: Any) -> None:
        with self._lock:
            self._conn.send(msg)

    def recv(self) -> Any:
        return self._conn.recv()

    def poll(self) -> bool:
        return self._conn.poll()


def _heartbeat(pipe: _Pipe, period_s: float) -> None:
    # A thread of its own, so it beats while the main thread renders (numba releases the GIL
    # between kernel calls, which are short) and stops only when the whole process does.
    while True:
        try:
            pipe.send(("beat", os.getpid()))
        except (OSError, EOFError, ValueError):
            return  # the parent has gone away
        time.sleep(period_s)


def main(conn: Connection, warmup: bool, block_frames: int, heartbeat_s: float = 1.0,
         nice: int = 0, threads: int = 1) -> None:
    """Entry point of a worker process; ``nice`` is added to its niceness (GUITAR_WORKER_NICE:
    renders behind the API process and the live workers, which need the CPU on time); each render
    on ``threads`` threads (``engine.mix``)."""
    # Ctrl-C reaches the whole process group; the parent decides when workers stop.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if nice:
        os.nice(nice)  # lowering one's own priority needs no privilege
    conn = _Pipe(conn)  # type: ignore[assignment]
    threading.Thread(target=_heartbeat, args=(conn, heartbeat_s), name="heartbeat",
                     daemon=True).start()
    import engine

    t0 = time.perf_counter()
    if warmup:
        if not engine.kernels_cached(engine.KERNEL_SCENES):
            conn.send(("warming", os.getpid(), "compiling kernels, first run only (one worker "
                       "compiles, the others wait and load them)"))
        warm_up(engine)
    frozen = heap.freeze_warm_up()
    try:
        conn.send(("ready", os.getpid(), time.perf_counter() - t0, frozen))
        _serve(conn, engine, block_frames, threads)
    except (BrokenPipeError, EOFError, ConnectionResetError):
        pass  # the parent has gone away


def warm_up(engine: Any) -> None:
    """Load what the requests use, before the worker says ready: every numba kernel path
    (compiled, or loaded from NUMBA_CACHE_DIR), libsndfile with its codecs, and the labels'
    libraries (jams, with pandas and mir_eval: seconds and tens of MiB), which every job uses.
    No request pays for an import (a score's preparation: ``service.validation`` and
    ``service.errors``, with FastAPI's modules), and the worker's memory is flat from here
    (``benchmarks/worker_memory.py``)."""
    engine.warmup()
    for fmt in ("wav", "flac", "ogg"):
        audio.encode(np.zeros(64), 44100, fmt)
    engine.scene_labels({"duration": 0.1, "events": [
        {"type": "pluck", "time": 0.0, "string": 1, "force": 1.0}]}).dumps()
    from . import errors, validation  # noqa: F401 - a score's preparation (_score): fastapi's modules


def _serve(conn: Connection, engine: Any, block_frames: int, threads: int = 1) -> None:
    while True:
        msg = conn.recv()
        if msg is None:
            return
        kind, job_id = msg[0], msg[1]
        if kind == "cancel":
            continue  # the job it meant already finished
        try:
            if kind == "render":
                _render(conn, engine, job_id, msg[2], threads)
            elif kind == "stream":
                _stream(conn, engine, job_id, msg[2], block_frames, threads)
            elif kind == "score":
                _score(conn, job_id, msg[2])
            elif kind == "labels":
                _labels(conn, job_id, msg[2])
        except (BrokenPipeError, ConnectionResetError, EOFError):
            raise  # the parent has gone, or asked this worker to stop during a render's cancel check
        except Exception as exc:  # reported to the parent, which maps it to a status code
            conn.send(("error", job_id, *_classify(exc)))
        finally:
            _give_back_memory()


def _give_back_memory() -> None:
    """After each job, return to the system the heap pages the job freed (``service.heap.trim``).
    After a mix of songs of different sizes a worker's heaps held free holes that no later job
    fit, and its resident memory crept up job after job under the mixed load
    (``benchmarks.mixed_load``)."""
    heap.trim()


def _score(conn: Connection, job_id: int, payload: dict[str, Any]) -> None:
    """Import a score (``engine.score_to_scene``) from the uploaded bytes, or take the JSON of an
    import the parent kept (``imported``).  A file the importer refuses (``ScoreError``) is the
    client's problem; so is one that trips the importer in any other way (a hostile or corrupt
    file reaching a path its checks missed): both are ``invalid`` (422) with the reason, and the
    worker carries on.

    The scene is then made ready to render here (``prepare``: the scene's own options and output
    fields): the options set, validated (``fields``: pydantic's errors as JSON) and measured
    (``service.validation.Figures``), so the API process never parses a whole song's scene.  The
    answer is that scene's JSON, with the import's own JSON in ``meta["imported"]`` (for the
    parent's cache) when it was imported now."""
    import engine

    t0 = time.perf_counter()
    raw = payload.get("imported")
    warnings: list[str] = []
    if raw is None:
        result = _import(conn, job_id, payload, engine)
        if result is None:
            return
        scene = dict(result)
        warnings = list(getattr(result, "warnings", []))
        raw = json.dumps(scene, allow_nan=False).encode()
    else:
        scene = json.loads(raw)
    events = len(scene.get("events") or []) + sum(
        len(t.get("events") or []) for t in scene.get("tracks") or [])
    most = payload.get("max_events")
    if most is not None and events > most:
        # Refused here, in one line: the API process never parses (or echoes) megabytes of scene.
        conn.send(("error", job_id, "invalid",
                   f"the score becomes {events} events; at most {most} are rendered "
                   f"({payload.get('max_events_setting', 'the limit')}): choose fewer tracks "
                   "(options.tracks) or a shorter part (options.max_seconds)"))
        return
    from pydantic import ValidationError

    from .errors import portable_errors
    from .validation import Figures

    prepare = payload["prepare"]
    for key in ("quality", "model"):
        if prepare.get(key) is not None:
            scene[key] = prepare[key]
    scene["output"] = {**scene.get("output", {}), **(prepare.get("output") or {})}
    try:
        sc = engine.Scene.model_validate(scene)
    except ValidationError as exc:
        conn.send(("error", job_id, "fields",
                   json.dumps(portable_errors(exc.errors(include_url=False)))))
        return
    ready = json.dumps(scene, allow_nan=False).encode()
    conn.send(("done", job_id, ready, {
        "warnings": warnings, "duration": scene.get("duration"), "events": events,
        "figures": Figures.of(sc).as_dict(), "seconds": time.perf_counter() - t0,
        "imported": raw if payload.get("imported") is None else None}))


def _import(conn: Connection, job_id: int, payload: dict[str, Any], engine: Any) -> Any:
    """The importer's result, or None when it refused the file (the refusal sent)."""
    source = io.BytesIO(payload["data"])
    source.name = payload.get("filename") or ""  # the importer's messages name the file
    try:
        return engine.score_to_scene(source, **payload["options"])
    except engine.ScoreError as exc:
        conn.send(("error", job_id, "invalid", str(exc)))
    except MemoryError:
        conn.send(("error", job_id, "invalid", "the score needs more memory than a worker has"))
    except Exception as exc:
        name = payload.get("filename") or "the file"
        conn.send(("error", job_id, "invalid",
                   f"{name} could not be read as a score ({type(exc).__name__}: {exc})"))
    return None


def _scene(payload: dict[str, Any]) -> Any:
    """The payload's scene: a dict, or its JSON (a score's scene as ``_score`` made it)."""
    scene = payload["scene"]
    return json.loads(scene) if isinstance(scene, bytes | str) else scene


def _labels(conn: Connection, job_id: int, payload: dict[str, Any]) -> None:
    """The scene's note labels as JAMS (``engine.scene_labels``), serialized as JSON."""
    import engine

    t0 = time.perf_counter()
    jam = engine.scene_labels(_scene(payload))
    conn.send(("done", job_id, jam.dumps().encode(), {"seconds": time.perf_counter() - t0}))


def _classify(exc: Exception) -> tuple[str, str]:
    from pydantic import ValidationError

    if isinstance(exc, FloatingPointError):
        return "non_finite", str(exc)
    if isinstance(exc, ValidationError):
        return "invalid", str(exc)
    return "internal", f"{type(exc).__name__}: {exc}"


def _check_finite(x: np.ndarray) -> None:
    # The engine raises on a non-finite state; this guards the output itself.
    if not np.all(np.isfinite(x)):
        raise FloatingPointError("the rendered audio contains non-finite samples")


def _render(conn: Connection, engine: Any, job_id: int, payload: dict[str, Any],
            threads: int = 1) -> None:
    """The scene's file; with ``output.stems``, a zip of it and its stems (``audio.stems_zip``),
    the stems kept in a temporary file while the render runs rather than in memory."""
    t0 = time.perf_counter()
    scene = _scene(payload)
    stems = bool((scene.get("output") or {}).get("stems"))
    cancelled = lambda: _cancel_requested(conn, job_id)  # noqa: E731 - the client has gone
    with tempfile.TemporaryFile() if stems else contextlib.nullcontext() as spill:
        try:
            if stems:
                result = engine.render_result(
                    scene, jobs=threads, cancelled=cancelled,
                    on_stems=lambda b: spill.write(np.ascontiguousarray(b, dtype="<f8").tobytes()))
            else:
                result = engine.render_result(scene, jobs=threads, stems=False,
                                              cancelled=cancelled)
        except engine.RenderCancelled:
            conn.send(("cancelled", job_id))
            return
        seconds = time.perf_counter() - t0
        samples = result.audio
        _check_finite(samples)
        data = audio.encode(samples, payload["sample_rate"], payload["format"],
                            payload["subtype"], payload["channels"])
        if stems:
            spill.flush()
            data = audio.stems_zip(data, spill, result.stem_layout, result.gain,
                                   payload["sample_rate"], payload["format"], payload["subtype"],
                                   payload.get("name", "guitar"))
    meta = {
        "render_seconds": seconds,
        "frames": int(audio.as_frames(samples, payload["channels"]).shape[0]),
        "energy_error": result.energy_error,
        "warnings": result.warnings,
    }
    conn.send(("done", job_id, data, meta))


def _cancel_requested(conn: Connection, job_id: int) -> bool:
    while conn.poll():
        msg = conn.recv()
        if msg is None:
            raise EOFError("stop requested")
        if msg[0] == "cancel" and msg[1] == job_id:
            return True
    return False


def _sample_bytes(block: np.ndarray, subtype: str) -> bytes:
    """A block for the client (``audio.pcm_bytes``), or, ``FLOAT64``, its float64 samples as
    they are (no clipping), for a job that scales or converts the whole file afterwards."""
    if subtype == "FLOAT64":
        return np.ascontiguousarray(block, dtype="<f8").tobytes()
    return audio.pcm_bytes(block, subtype)


def _stream(conn: Connection, engine: Any, job_id: int, payload: dict[str, Any],
            block_frames: int, threads: int = 1) -> None:
    t0 = time.perf_counter()
    frames, subtype, channels = payload["frames"], payload["subtype"], payload["channels"]
    stems = payload.get("stems", False)
    sent = 0
    scene = _scene(payload)
    scene["diagnostics"] = False  # energy terms cost time and a stream cannot report them
    blocks = engine.blocks(scene, block_frames=block_frames,
                           raw=payload.get("raw", False), jobs=threads, stems=stems)
    warnings = blocks.warnings  # sent with the first block, before the response's headers
    if stems:  # a job's: its stems ride as columns after the mix's
        channels += len(blocks.stem_layout)
    for block in blocks:
        if stems:
            block = np.column_stack((audio.as_frames(block[0], payload["channels"]), block[1]))
        block = audio.as_frames(block, channels)
        _check_finite(block)
        # The header announced ``frames``: never send more than that.
        block = block[: frames - sent]
        if len(block):
            conn.send(("block", job_id, _sample_bytes(block, subtype), time.perf_counter() - t0,
                       warnings))
            sent += len(block)
            warnings = []
        if _cancel_requested(conn, job_id):
            conn.send(("cancelled", job_id))
            return
    if sent < frames:
        # Keep the file valid if the blocks ever fall short of engine.frame_count (the header's).
        silence = audio.as_frames(np.zeros((frames - sent) * channels), channels)
        conn.send(("block", job_id, _sample_bytes(silence, subtype), time.perf_counter() - t0,
                   warnings))
    # scale: the stream's samples per m/s of pickup velocity
    conn.send(("end", job_id, {"render_seconds": time.perf_counter() - t0, "frames": sent,
                               "warnings": warnings,
                               "scale": 1.0 if payload.get("raw") else engine.FIXED_GAIN}))
