"""The job runner: takes queued jobs from the store and renders them through the worker pool.

Each job is a stream (``WorkerPool.job_stream``) whose blocks are written to
``results/ID/stream.wav.part`` as they arrive; progress is the share of the file written.  When the
last block is in, the file is flushed, normalized (``output.normalize``, the default, as /render)
or converted (FLAC, Ogg) block by block if the scene asks for it, renamed into place, the labels
are written the same way, and only then is the job ``done``.  A job with ``output.stems`` streams
its stems as columns after the mix's; they become ``stems.zip``, laid out as ``/render``'s.

At most ``Settings.jobs_at_once`` jobs render at once (by default every worker but one), so that
long jobs never take every worker from ``/render``.  On shutdown the running jobs go back to the
queue (their attempt not counted); if the process is killed instead, ``Store.recover`` queues them
again at the next start.  Either way a job is re-run from its start: a render is deterministic, so
the result is the same.
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import os
import time
from pathlib import Path
from typing import Any

import engine

from .. import audio
from ..config import Settings
from ..exceptions import PoolBusy, PoolClosed, PoolError, RenderFailed, StreamAborted, WorkerDied
from ..pool import RenderStream, WorkerPool
from .store import Store

log = logging.getLogger("service.jobs")

PROGRESS_INTERVAL_S = 0.25  # how often a running job's progress is written to the database
CLEANUP_INTERVAL_S = 60.0


class JobRunner:
    def __init__(self, store: Store, pool: WorkerPool, settings: Settings):
        self.store = store
        self.pool = pool
        self.settings = settings
        self._wake = asyncio.Event()
        self._tasks: list[asyncio.Task] = []
        self._streams: dict[str, RenderStream] = {}
        self._claimed: set[str] = set()  # jobs this runner has taken and not yet finished
        self._stopping = False
        self.completed: dict[str, int] = {"done": 0, "failed": 0, "cancelled": 0, "requeued": 0}

    async def start(self) -> None:
        requeued, failed = self.store.recover(self.settings.job_max_attempts)
        if requeued or failed:
            log.warning("jobs cut off by the last shutdown",
                        extra={"fields": {"requeued": requeued, "failed": failed}})
        self.cleanup()
        for i in range(self.settings.jobs_at_once):
            self._tasks.append(asyncio.create_task(self._loop(), name=f"job-runner-{i}"))
        self._tasks.append(asyncio.create_task(self._cleanup_loop(), name="job-cleanup"))

    async def stop(self) -> None:
        """Put the running jobs back in the queue and stop their renders."""
        self._stopping = True
        for job_id in list(self._claimed):  # rendering, or still waiting for a worker
            self.store.requeue(job_id, count_attempt=False)
        for stream in list(self._streams.values()):
            stream.close()
        for t in self._tasks:
            t.cancel()
        for t in self._tasks:
            with contextlib.suppress(asyncio.CancelledError, Exception):
                await t
        self._tasks.clear()

    def wake(self) -> None:
        self._wake.set()

    def cancel(self, job_id: str) -> None:
        """Stop a running job's render (its status is already ``cancelled`` in the store)."""
        stream = self._streams.get(job_id)
        if stream is not None:
            stream.close()

    @property
    def running(self) -> int:
        return len(self._streams)

    def cleanup(self) -> None:
        """Old jobs and their folders deleted, the store's WAL checkpointed: file-system work
        that ``_cleanup_loop`` runs in a thread."""
        gone = self.store.cleanup(self.settings.job_retention_s, self.settings.max_jobs)
        if gone:
            log.info("old jobs deleted", extra={"fields": {"jobs": len(gone)}})
        self.store.checkpoint()

    async def _cleanup_loop(self) -> None:
        while True:
            await asyncio.sleep(CLEANUP_INTERVAL_S)
            try:
                await asyncio.to_thread(self.cleanup)
            except Exception as exc:  # a full disk must not stop the service
                log.error("job cleanup failed", extra={"fields": {"error": str(exc)}})

    async def _loop(self) -> None:
        while not self._stopping:
            job = self.store.claim_next()
            if job is None:
                self._wake.clear()
                with contextlib.suppress(TimeoutError):
                    await asyncio.wait_for(self._wake.wait(), 5.0)
                continue
            self._wake.set()  # another runner may take the next one
            self._claimed.add(job["id"])
            try:
                await self._run(job)
            except asyncio.CancelledError:
                raise
            except Exception as exc:  # a bug here must fail the job, not the runner
                log.exception("job runner error")
                self._finish(job["id"], "failed", error=f"internal error: {exc}")
            finally:
                if not self._stopping:
                    self._claimed.discard(job["id"])

    def _finish(self, job_id: str, status: str, **fields: Any) -> None:
        self.store.finish(job_id, status, **fields)
        self.completed[status] += 1
        log.info("job finished", extra={"fields": {"job": job_id, "status": status, **{
            k: v for k, v in fields.items() if k in ("error", "audio_seconds", "render_seconds")}}})

    async def _run(self, job: dict[str, Any]) -> None:
        job_id = job["id"]
        # a whole song's JSON is parsed beside the event loop; the worker gets the text
        out, rate, stems = await asyncio.to_thread(_layout, job["scene"])
        subtype = out.get("subtype", "PCM_16")
        normalize = out.get("normalize", True)
        # A file to be normalized or converted is streamed as raw float64 samples (the pickup
        # velocity when it is normalized), then scaled and encoded block by block as /render
        # scales and encodes the whole signal: the same bytes.
        rewrite = normalize or job["format"] != "wav" or bool(stems)
        stream_subtype = "FLOAT64" if rewrite else subtype
        channels = out.get("channels", 1)
        frames = round(job["duration"] * rate)
        folder = self.store.job_dir(job_id)
        folder.mkdir(parents=True, exist_ok=True)
        part = folder / "stream.wav.part"  # not audio.wav.part: that is where _finalize writes
        header = b"" if rewrite else audio.wav_header(frames, rate, stream_subtype, channels)
        total = len(header) + frames * (channels + len(stems)) * (
            8 if rewrite else audio.BYTES_PER_SAMPLE[stream_subtype])
        payload = {"scene": job["scene"], "frames": frames,
                   "subtype": stream_subtype, "channels": channels, "raw": normalize,
                   "stems": bool(stems)}
        cost = job.get("cost")
        limit = self.settings.time_limit_s(job["duration"], cost)
        t0 = time.perf_counter()
        stream: RenderStream | None = None
        try:
            # a row without an estimate (older store) waits as a heavy render would
            stream = await self.pool.job_stream(
                payload, limit, cost=self.settings.heavy_render_s if cost is None else cost)
            self._streams[job_id] = stream
            if self.store.get(job_id)["status"] != "running":  # cancelled while it waited
                return
            written = await self._write(job_id, stream, part, header, total)
            if written != total:
                raise StreamAborted(f"the stream ended after {written} of {total} bytes")
            final = folder / f"audio.{job['format']}"
            await asyncio.to_thread(_finalize, part, final, job["format"], subtype, normalize,
                                    rewrite, rate, channels, stems, stream.scale)
            labels_error = await self._labels(job["scene"], self.store.labels_path(job_id))
            self._finish(job_id, "done", progress=1.0, audio_seconds=frames / rate,
                         render_seconds=time.perf_counter() - t0, warnings=stream.warnings,
                         labels=int(labels_error is None), labels_error=labels_error)
        except PoolClosed:
            self.store.requeue(job_id, count_attempt=False)
        except (WorkerDied, StreamAborted) as exc:
            if self._stopping:
                return  # stop() has put it back in the queue
            if self.store.get(job_id)["status"] == "cancelled":
                return
            if isinstance(exc, WorkerDied) and job["attempts"] < self.settings.job_max_attempts:
                self.store.requeue(job_id, count_attempt=True)
                self.completed["requeued"] += 1
                self.wake()
            else:
                self._finish(job_id, "failed", error=str(exc))
        except RenderFailed as exc:
            reason = exc.message if exc.kind != "non_finite" else (
                f"the simulation became unstable ({exc.message}); lower the forces or use "
                "quality 'high'")
            self._finish(job_id, "failed", error=reason)
        except PoolError as exc:  # RenderTimeout
            self._finish(job_id, "failed", error=str(exc))
        except OSError as exc:  # a full disk, a folder gone
            self._finish(job_id, "failed", error=f"could not write the result: {exc}")
        finally:
            self._streams.pop(job_id, None)
            if stream is not None:
                stream.close()
            with contextlib.suppress(OSError):
                part.unlink()

    async def _labels(self, scene: str, path: Path) -> str | None:
        """The scene's JAMS labels, made in a worker (``engine.scene_labels``, as
        ``POST /scene/labels``) and renamed into place; the reason when there are none (the
        audio is still the job's result)."""
        for _ in range(60):
            try:
                raw, _meta = await self.pool.call("labels", {"scene": scene},
                                                  self.settings.score_import_time_limit_s)
                break
            except PoolBusy:  # /render traffic has every slot: the labels can wait
                await asyncio.sleep(1.0)
            except PoolClosed:
                raise
            except PoolError as exc:
                return str(exc)
        else:
            return "no worker was free to make the labels"
        tmp = path.with_name(path.name + ".part")
        await asyncio.to_thread(_write_atomically, tmp, path, raw)
        return None

    async def _write(self, job_id: str, stream: RenderStream, part: Path, header: bytes,
                     total: int) -> int:
        """Write the stream's blocks to ``part`` as they come.  The file's calls run in a thread:
        a write that the kernel holds back (dirty pages over their limit) or the final fsync of
        tens of MB may take seconds, and on the event loop they would stall every request and
        live session of the process for as long."""
        last = time.monotonic()
        f = await asyncio.to_thread(open, part, "wb")
        try:
            await asyncio.to_thread(f.write, header)
            written = len(header)
            async for chunk in stream.chunks():
                await asyncio.to_thread(f.write, chunk)
                written += len(chunk)
                if time.monotonic() - last > PROGRESS_INTERVAL_S:
                    last = time.monotonic()
                    self.store.set_progress(job_id, min(written / total, 0.999))
            await asyncio.to_thread(_flush_and_sync, f)
        finally:
            await asyncio.to_thread(f.close)
        return written


def _layout(text: str) -> tuple[dict[str, Any], int, list]:
    """A job's scene JSON: its output fields, its sample rate and its stems (when it asks for
    them)."""
    scene = json.loads(text)
    out = scene.get("output") or {}
    stems = engine.parse_scene(scene).stems() if out.get("stems") else []
    return out, scene.get("sample_rate", 44100), stems


def _flush_and_sync(f) -> None:
    f.flush()
    os.fsync(f.fileno())


STEMS_ZIP = "stems.zip"  # beside the audio (Store.stems_path)
PEAK_DBFS = -1.0  # as engine.output: a normalized file peaks here
_BLOCK = 1 << 16


def _raw_blocks(part: Path, width: int):
    """The float64 samples of a raw stream file, (frames, width), in blocks."""
    import numpy as np

    data = np.memmap(part, dtype="<f8", mode="r").reshape(-1, width)
    for at in range(0, len(data), _BLOCK):
        yield np.array(data[at:at + _BLOCK])


def _mix(block, channels: int):
    """The mix's columns of a raw block: (frames,) or (frames, channels)."""
    return block[:, 0] if channels == 1 else block[:, :channels]


def _finalize(part: Path, final: Path, fmt: str, subtype: str, normalize: bool,
              rewrite: bool, rate: int, channels: int, stems: list | None = None,
              scale: float | None = None) -> None:
    """The stream's WAV becomes the job's file by a rename; when it must be normalized or
    converted (FLAC, Ogg, another WAV subtype) the raw float64 stream is scaled and encoded block
    by block, with /render's arithmetic (``engine.output.to_output_scale``: the velocity times
    the one gain that puts its peak at PEAK_DBFS) and encoder (``service.audio``), so the file
    has /render's bytes and a ten-minute job never holds its audio in memory.  ``stems`` (their
    ``engine.Stem``s; ``scale``: the stream's samples per m/s) ride as columns after the mix's
    and are written the same way, at the mix's gain (normalized, the one that puts the loudest
    of the mix and the stems at PEAK_DBFS, as /render), into ``stems.zip`` beside it."""
    if not rewrite:
        os.replace(part, final)
        return
    import numpy as np
    import soundfile as sf

    width = channels + len(stems or [])
    gain = None
    if normalize:  # the loudest of the mix and its stems (every column) at PEAK_DBFS
        peak = 0.0
        for block in _raw_blocks(part, width):
            peak = max(peak, float(np.max(np.abs(block))) if block.size else 0.0)
        gain = 10.0 ** (PEAK_DBFS / 20.0) / peak if peak > 0 else None
    tmp = final.with_name(final.name + ".part")
    frames = os.path.getsize(part) // (8 * width)
    if fmt == "wav":
        with open(tmp, "wb") as f:
            f.write(audio.wav_header(frames, rate, subtype, channels))
            for block in _raw_blocks(part, width):
                x = _mix(block, channels)
                f.write(audio.pcm_bytes(x if gain is None else x * gain, subtype))
    else:
        with sf.SoundFile(str(tmp), "w", samplerate=rate, channels=channels,
                          format=fmt.upper(), subtype=_file_subtype(fmt, subtype)) as f:
            for block in _raw_blocks(part, width):
                x = _mix(block, channels)
                f.write(audio.clip(x if gain is None else x * gain))
    if stems:
        _stems_zip(part, final.with_name(STEMS_ZIP), stems, width, channels, gain,
                   (1.0 if gain is None else gain) * (scale or 1.0), frames, rate, fmt, subtype)
    os.replace(tmp, final)


def _file_subtype(fmt: str, subtype: str) -> str:
    return {"flac": "PCM_16" if subtype == "PCM_16" else "PCM_24", "ogg": "VORBIS"}[fmt]


def _stems_zip(part: Path, final: Path, stems: list, width: int, channels: int,
               gain: float | None, per_m_s: float, frames: int, rate: int, fmt: str,
               subtype: str) -> None:
    """The stems' columns of the raw stream as one file each (``stems/t1-s6.FMT`` ..., and
    ``stems/stems.json``), in one pass, then zipped: /render's zip without the mix."""
    import shutil
    import zipfile

    import numpy as np
    import soundfile as sf

    work = final.with_name(final.name + ".dir")
    work.mkdir(exist_ok=True)
    paths = [work / f"{s.label}.{fmt}" for s in stems]
    clipped = 0
    try:
        if fmt == "wav":
            files = [open(p, "wb") for p in paths]  # noqa: SIM115 (closed below)
            for f in files:
                f.write(audio.wav_header(frames, rate, subtype, 1))
        else:
            files = [sf.SoundFile(str(p), "w", samplerate=rate, channels=1, format=fmt.upper(),
                                  subtype=_file_subtype(fmt, subtype)) for p in paths]
        try:
            for block in _raw_blocks(part, width):
                x = block[:, channels:] if gain is None else block[:, channels:] * gain
                clipped += int(np.count_nonzero(np.abs(x) > 1.0))
                for k, f in enumerate(files):
                    col = np.ascontiguousarray(x[:, k])
                    f.write(audio.pcm_bytes(col, subtype) if fmt == "wav" else audio.clip(col))
        finally:
            for f in files:
                f.close()
        info = engine.stems_index(stems, fmt, rate, per_m_s, clipped)
        tmp = final.with_name(final.name + ".part")
        mode = zipfile.ZIP_DEFLATED if fmt == "wav" else zipfile.ZIP_STORED
        with zipfile.ZipFile(tmp, "w", mode, compresslevel=1 if fmt == "wav" else None) as z:
            for p in paths:
                z.write(p, f"stems/{p.name}")
            z.writestr("stems/stems.json", json.dumps(info, indent=1) + "\n")
        os.replace(tmp, final)
    finally:
        shutil.rmtree(work, ignore_errors=True)


def _write_atomically(tmp: Path, final: Path, data: bytes) -> None:
    with open(tmp, "wb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, final)
