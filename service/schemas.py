"""Response models of the service's JSON endpoints (the request model is the engine's ``Scene``)."""

from __future__ import annotations

from pydantic import BaseModel, Field


class PoolStatus(BaseModel):
    workers: int = Field(description="configured worker processes")
    workers_ready: int = Field(description="workers warmed up and alive now")
    busy: int = Field(description="workers rendering now")
    in_flight: int = Field(description="renders admitted (running or waiting)")
    capacity: int = Field(description="workers + queue size; more renders are answered 503")
    replaced: int = Field(description="workers replaced since start (killed, timed out, crashed)")
    heavy_in_flight: int = Field(0, description="heavy renders admitted (running or waiting)")
    heavy_capacity: int = Field(0, description="heavy slots + their queue; more heavy renders "
                                               "are answered 503")
    hung: int = Field(0, description="workers killed since start for missing heartbeats")
    warming: str | None = Field(None, description="what a worker warming up is doing when it "
                                                  "takes long (compiling the kernels, on a "
                                                  "machine's first start); null otherwise")


class Health(BaseModel):
    status: str = Field(description="'ok': a worker can take a render; 'degraded': warmed up "
                                    "once, workers being replaced; 'starting': before the first "
                                    "warm-up or no worker alive")
    ready: bool = Field(description="a worker can take a render now")
    pool: PoolStatus


class StringInfo(BaseModel):
    string: int = Field(description="1 = highest string")
    note: str = Field(description="open-string pitch, scientific notation")
    frequency_hz: float
    tension_n: float = Field(description="tension that tunes the simulated string, N")
    radius_m: float
    density_kg_m3: float
    youngs_modulus_pa: float
    linear_density_kg_m: float
    t60_fundamental_s: float
    t60_2khz_s: float
    saddle_setback_m: float = Field(
        description="intonation compensation at the saddle: speaking length beyond the scale, m")
    nut_compensation_m: float = Field(
        description="intonation compensation at the nut: the nut moved this far towards the "
                    "frets, m (the open string speaks over scale + setback - this)")


class FingerInfo(BaseModel):
    mass_kg: float
    stiffness: float
    alpha: float
    damping_n_s_m: float


class PresetInfo(BaseModel):
    name: str
    description: str
    default: bool = Field(description="used when a scene names no preset")
    scale_length_m: float
    frets: int
    action_nut_m: float
    action_12th_m: float
    fret_height_m: float
    pickup_position: float = Field(description="default output point, x / L")
    body: str = Field(description="built-in body response used when the scene's output names none "
                      "(`none`: a solid body)")
    tuning: list[str] = Field(description="open-string notes, string 1 first")
    strings: list[StringInfo]
    finger: FingerInfo


class Presets(BaseModel):
    default: str
    presets: list[PresetInfo]


class Limits(BaseModel):
    """The service's limits on a scene, on top of the engine schema's own ranges."""

    max_body_bytes: int
    max_duration_s: float
    max_events: int
    max_score_events: int = Field(description="events the scene of an uploaded score may hold "
                                              "(POST /render/score)")
    score_formats: list[str] = Field(description="file suffixes POST /score/scene and "
                                                 "/render/score accept")
    max_expanded_events: int = Field(description="events once strums and string-less mutes "
                                                 "and damps count once per string")
    min_sample_rate: int
    max_sample_rate: int
    time_limit_base_s: float
    time_limit_per_audio_s: float
    time_limit_per_estimated_s: float = Field(
        description="time limit = min(base + per_audio x duration, base + this x estimated s)")
    max_render_s: float = Field(description="a scene whose estimated render time is longer is "
                                            "refused (422)")
    heavy_render_s: float = Field(description="renders estimated longer than this share fewer "
                                              "workers (all but one by default)")
    work_per_second: float = Field(description="work units (engine.estimate_cost) per second: "
                                               "estimated s = work / this")
    stream_formats: list[str]
    formats: list[str]
    job_max_duration_s: float = Field(description="longest scene a job (POST /jobs) may render")
    job_max_events: int
    job_max_render_s: float = Field(description="a job estimated to take longer is refused")
    job_max_per_client: int = Field(description="jobs one client may have queued or running")
    live_max_messages_per_s: int = Field(description="messages a live session may send in a "
                                                     "second before it is closed (4429)")
