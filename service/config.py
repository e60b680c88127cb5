"""Service settings: every limit and knob of the HTTP layer, read from ``GUITAR_*`` environment
variables (pydantic-settings).  The engine's own schema limits (``engine.scene``) still apply; these
are the tighter limits a public server puts on top of them.  ``docs/service.md`` tabulates them.
"""

from __future__ import annotations

import os

from pydantic import Field, model_validator
from pydantic_settings import BaseSettings, SettingsConfigDict

from engine.scene import MAX_DURATION_S, MAX_EVENTS, SAMPLE_RATE_MAX, SAMPLE_RATE_MIN


def _default_workers() -> int:
    # The CPUs this process may run on (a container's cpuset), not every CPU of the host.
    if hasattr(os, "sched_getaffinity"):
        return max(1, len(os.sched_getaffinity(0)))
    return max(1, os.cpu_count() or 1)


class Settings(BaseSettings):
    model_config = SettingsConfigDict(env_prefix="GUITAR_", extra="ignore")

    # Worker pool
    workers: int = Field(default_factory=_default_workers, ge=1, le=64,
                         description="render worker processes (default: one per core)")
    queue_size: int = Field(8, ge=0, le=10_000,
                            description="renders that may wait for a worker; more get 503")
    queue_timeout_s: float = Field(30.0, gt=0.0,
                                   description="longest wait for a free worker before 503")
    retry_after_s: int = Field(2, ge=1, description="Retry-After sent with a 503")
    warmup: bool = Field(True, description="render tiny scenes in each worker at start-up "
                                           "(engine.warmup: every kernel compiled or loaded)")
    mp_context: str = Field("spawn", pattern="^(spawn|forkserver)$",
                            description="multiprocessing start method of the workers")
    worker_nice: int = Field(0, ge=0, le=19,
                             description="added to the render workers' niceness: renders run "
                                         "behind the API process and the live workers")

    # Time limit of one render (seconds of wall time): the smaller of
    #   base + per_audio_second * duration   and   base + per_estimated * estimated seconds
    time_limit_base_s: float = Field(10.0, gt=0.0)
    # 20: the costliest scene admitted (six fingered strings at 96 kHz, quality high) takes about
    # 4 s per second of audio on an idle core, so a cap of 5 killed it as soon as the machine was
    # busy; the estimate's limit (4 times it) is the tighter one for most scenes
    time_limit_per_audio_s: float = Field(20.0, ge=0.0)
    time_limit_per_estimated_s: float = Field(
        4.0, ge=1.0, description="time limit per second of the render's cost estimate")

    # Cost: engine.estimate_cost(scene).work / work_per_second = the estimated seconds of a render
    work_per_second: float = Field(
        1.5e8, gt=0.0, description="the engine's stepping throughput, work units per second "
                                   "(benchmarks/cost.py prints it for this machine)")
    max_render_s: float = Field(
        60.0, gt=0.0, description="budget: a scene estimated to take longer is refused (422)")
    heavy_render_s: float = Field(
        5.0, gt=0.0, description="a render estimated to take longer is heavy: it may use only "
                                 "heavy_workers workers, so the others stay free for small ones")
    heavy_workers: int | None = Field(
        None, ge=1, description="workers heavy renders may hold at once (default: all but one)")
    heavy_queue_size: int = Field(
        2, ge=0, description="heavy renders that may wait for a heavy slot; more get 503")

    # Liveness of the workers
    heartbeat_s: float = Field(1.0, gt=0.0, description="how often a worker says it is alive")
    heartbeat_timeout_s: float = Field(
        15.0, gt=0.0, description="a worker silent this long is hung: killed and replaced")
    disconnect_poll_s: float = Field(
        0.25, gt=0.0, description="how often a waiting render checks that its client is there")

    # Request limits (tighter than, or equal to, the engine's schema limits)
    max_body_bytes: int = Field(256 * 1024, ge=1024)
    max_duration_s: float = Field(30.0, gt=0.0, le=MAX_DURATION_S)
    max_events: int = Field(500, ge=1, le=MAX_EVENTS)
    # A score plays many more notes per second than a hand-written scene: its own event limit
    # (POST /render/score), still bounded by duration and the render's time limit.
    max_score_events: int = Field(5000, ge=1, le=MAX_EVENTS)
    score_import_time_limit_s: float = Field(
        10.0, gt=0.0, description="wall time a worker may spend importing one score file")
    score_cache_mb: float = Field(
        64.0, ge=0.0, description="MB of imported scores kept in the API process, so that a file "
                                  "read again with the same options is not imported again; 0: none")
    api_mmap_threshold_kib: int = Field(
        128, ge=0, le=32768,
        description="KiB from which the API process's C heap (glibc) serves a block from a "
                    "mapping of its own, returned to the system when freed (request and response "
                    "bodies); glibc's default threshold rises with the largest block freed, and "
                    "the heap then kept growing under a mixed load; 0: glibc's default")
    max_expanded_events: int = Field(
        3000, ge=1,
        description="events once strums and string-less mutes and damps count once per string")
    min_sample_rate: int = Field(SAMPLE_RATE_MIN, ge=SAMPLE_RATE_MIN)
    max_sample_rate: int = Field(SAMPLE_RATE_MAX, le=SAMPLE_RATE_MAX)

    render_threads: int = Field(
        1, ge=1, le=64,
        description="threads each render (HTTP or job) computes its strings on; the samples are "
                    "the same for any number. Keep workers x render_threads at the cores: 1 with a "
                    "worker per core, the cores with a single worker (one long song at a time, "
                    "fast)")
    compile_jobs: int | None = Field(
        None, ge=1, le=64,
        description="child processes that compile the numba kernels at once when they are not "
                    "in the cache (a first start), one per string model; read by the engine "
                    "from the environment. Default: the cores; 1 compiles one model after the "
                    "other, where memory is short")

    # Streaming
    # a multiple of 1024: the waveguide model's blocks then give the samples of a whole render
    # (engine/waveguide/voice.py, BLOCK_MULTIPLE)
    stream_block_frames: int = Field(4096, ge=1024, le=1 << 20, multiple_of=1024,
                                     description="frames per streamed block")

    # Live play (WS /live): sessions run in processes of their own (service/live.py)
    live_workers: int = Field(1, ge=0, le=16,
                              description="live-session worker processes (0: WS /live refused)")
    live_prestart: bool = Field(False, description="start the live workers with the server (default: "
                                                   "on the first WS /live session)")
    live_start_timeout_s: float = Field(180.0, gt=0.0, description="how long a first session "
                                        "waits for a live worker to warm up")
    max_live_sessions: int = Field(4, ge=0, le=1000,
                                   description="live sessions open at once; more are refused")
    live_idle_timeout_s: float = Field(60.0, gt=0.0,
                                       description="a session with no message for this long is "
                                                   "closed")
    live_lead_ms: float = Field(20.0, ge=0.0, le=1000.0,
                                description="how far ahead of real time blocks are computed and "
                                            "sent")
    live_nice: int = Field(0, ge=-20, le=19,
                           description="niceness of the live workers (negative: ahead of renders "
                                       "and other load; needs CAP_SYS_NICE, else ignored)")
    live_realtime_priority: int = Field(
        0, ge=0, le=99, description="SCHED_RR priority of the live workers' audio thread (1-99: "
                                    "it preempts every normally scheduled process at once, as "
                                    "audio servers' threads do; 0: normal scheduling; needs "
                                    "CAP_SYS_NICE, else ignored)")
    relay_realtime_priority: int = Field(
        0, ge=0, le=99, description="SCHED_RR priority of the API process's event-loop thread, "
                                    "which hands every live block to its socket (1-99, below "
                                    "the live workers' audio thread; it preempts renders and "
                                    "other normally scheduled work, the kernel keeping 5 % of "
                                    "each second for them; 0: normal scheduling; needs "
                                    "CAP_SYS_NICE, else ignored)")
    live_max_events_per_s: int = Field(200, ge=1, description="events a session may send per "
                                                              "second; more are refused")
    live_max_messages_per_s: int = Field(
        400, ge=1, description="messages of any kind (valid or not) a session may send in any "
                               "second; more close it with 4429")

    # Clients: who is asking, for per-client quotas and fair shares (service/clients.py)
    api_keys: str = Field("", description="comma-separated API keys; a request whose X-API-Key "
                                          "header holds one is that key's client, any other "
                                          "is its peer address's")

    # Logging
    log_level: str = Field("INFO", description="level of the service's JSON logs")

    # Jobs (service/jobs/): long renders stored in SQLite under data_dir
    data_dir: str = Field("./data", description="directory of the job database and results")
    job_max_duration_s: float = Field(600.0, gt=0.0, le=MAX_DURATION_S,
                                      description="longest scene a job may render, s")
    job_max_events: int = Field(MAX_EVENTS, ge=1, le=MAX_EVENTS,
                                description="most events in a job's scene")
    job_concurrency: int = Field(0, ge=0, le=64,
                                 description="jobs rendering at once (0: workers - 1, at least 1)")
    job_retention_s: float = Field(7 * 24 * 3600.0, gt=0.0,
                                   description="finished jobs and their results are deleted after")
    max_jobs: int = Field(1000, ge=1, description="jobs kept; the oldest finished go first")
    job_max_attempts: int = Field(3, ge=1, le=100,
                                  description="runs of a job cut off by a restart or a dead worker")
    job_max_render_s: float = Field(
        600.0, gt=0.0, description="budget of one job: a scene estimated to take longer to "
                                   "render is refused (422)")
    job_max_per_client: int = Field(
        100, ge=1, description="jobs one client may have queued or running; more get 429")

    @model_validator(mode="after")
    def _ranges(self) -> Settings:
        if self.min_sample_rate > self.max_sample_rate:
            raise ValueError("min_sample_rate must not exceed max_sample_rate")
        return self

    @property
    def api_key_set(self) -> frozenset[str]:
        return frozenset(k.strip() for k in self.api_keys.split(",") if k.strip())

    @property
    def jobs_at_once(self) -> int:
        """Jobs rendering at once: one worker is left to /render unless there is only one."""
        return self.job_concurrency or max(1, self.workers - 1)

    def time_limit_s(self, duration_s: float, estimated_s: float | None = None) -> float:
        """Wall-time budget of one render of ``duration_s`` seconds of audio whose cost estimate
        is ``estimated_s`` seconds: the estimate makes it proportional to the work, so that a
        render far slower than its estimate is stopped long before the per-audio-second cap."""
        cap = self.time_limit_base_s + self.time_limit_per_audio_s * duration_s
        if estimated_s is None:
            return cap
        return min(cap, self.time_limit_base_s + self.time_limit_per_estimated_s * estimated_s)

    def estimated_seconds(self, work: float) -> float:
        return work / self.work_per_second

    def heavy_slots(self) -> int:
        return self.heavy_workers or max(1, self.workers - 1)
