"""The scene: what a user asks the engine to play (the JSON of ``../shared/API.md``).

This pydantic schema is the single definition of valid input for every front end (Python, HTTP, CLI).
Validation happens here, at the edge; the numerical kernels assume valid input and do not check.
Every limit below is a documented range, and every violation is reported with the field's location.
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from .presets import DEFAULT_PRESET, PRESETS, Preset, apply_overrides, get_preset, note_frequency

MAX_DURATION_S = 120.0
MAX_EVENTS = 2000
MAX_PLUCK_FORCE_N = 20.0
MAX_FINGER_FORCE_N = 10.0
# Default pressing force: enough to seat every string of the presets on frets 1-12 (the string must
# be pushed below the line from the next fret to the bridge; benchmarks/intonation.py uses it too).
FINGER_FORCE_N = 3.0
MAX_TAP_VELOCITY_M_S = 5.0
SAMPLE_RATE_MIN = 22050
SAMPLE_RATE_MAX = 96000


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


Position = Annotated[float, Field(gt=0.0, lt=1.0, description="x / L: 0 at the nut, 1 at the bridge")]


class _Event(_Model):
    time: float = Field(ge=0.0, description="start time, s (>= 0, < duration)")
    string: int = Field(ge=1, le=12, description="1 = highest string")


class Pluck(_Event):
    """A raised-sine force pulse f_e(t) of eq. (5) at ``position`` (paper sec. 2.1)."""

    type: Literal["pluck"] = "pluck"
    position: float = Field(0.8, ge=0.02, le=0.98, description="x_e / L")
    force: float = Field(2.0, gt=0.0, le=MAX_PLUCK_FORCE_N, description="peak force f_amp, N")
    duration: float = Field(0.001, ge=1e-4, le=0.05, description="pulse length Delta, s")

    model_config = ConfigDict(
        json_schema_extra={
            "examples": [{"type": "pluck", "time": 0.0, "string": 1, "position": 0.8, "force": 2.0}]
        }
    )


class Fret(_Event):
    """A finger pressed behind fret ``fret`` with ``force`` towards the fretboard (sec. 2.5)."""

    type: Literal["fret"] = "fret"
    fret: int = Field(ge=0, le=24, description="0 lifts the finger")
    force: float = Field(
        FINGER_FORCE_N, gt=0.0, le=MAX_FINGER_FORCE_N, description="pressing force, N"
    )
    release: float | None = Field(None, gt=0.0, description="time the finger lifts, s")

    model_config = ConfigDict(
        json_schema_extra={"examples": [{"type": "fret", "time": 0.0, "string": 5, "fret": 3}]}
    )


class Tap(_Event):
    """A finger that strikes the string at ``fret`` and stays pressed (paper Fig. 3c)."""

    type: Literal["tap"] = "tap"
    fret: int = Field(ge=1, le=24)
    force: float = Field(
        FINGER_FORCE_N, gt=0.0, le=MAX_FINGER_FORCE_N, description="pressing force, N"
    )
    velocity: float = Field(
        1.0, gt=0.0, le=MAX_TAP_VELOCITY_M_S, description="speed towards the fretboard, m/s"
    )
    release: float | None = Field(None, gt=0.0, description="time the finger lifts, s")

    model_config = ConfigDict(
        json_schema_extra={"examples": [{"type": "tap", "time": 0.0, "string": 3, "fret": 7}]}
    )


Event = Annotated[Pluck | Fret | Tap, Field(discriminator="type")]


class StringOverride(_Model):
    """Per-string physical overrides of a preset; omitted fields keep the preset's value."""

    string: int = Field(ge=1, le=12)
    note: str | None = Field(None, description="open-string pitch, e.g. 'D2'")
    radius_m: float | None = Field(None, ge=5e-5, le=2e-3)
    density_kg_m3: float | None = Field(None, ge=500.0, le=25000.0)
    youngs_modulus_pa: float | None = Field(None, ge=1e8, le=4e11)
    t60_fundamental_s: float | None = Field(None, ge=0.05, le=60.0)
    t60_2khz_s: float | None = Field(None, ge=0.02, le=60.0)
    saddle_setback_m: float | None = Field(
        None, ge=0.0, le=0.01, description="intonation compensation: length beyond the scale, m"
    )

    @field_validator("note")
    @classmethod
    def _note(cls, v: str | None) -> str | None:
        if v is None:
            return v
        f = note_frequency(v)  # raises ValueError with the name
        if not 25.0 <= f <= 1400.0:
            raise ValueError(f"pitch {v} = {f:.1f} Hz outside 25..1400 Hz")
        return v


class Guitar(_Model):
    preset: str = Field(DEFAULT_PRESET, description=f"one of {sorted(PRESETS)}")
    tuning: list[str] | None = Field(
        None, description="open-string notes, string 1 first (e.g. ['D4','B3','G3','D3','G2','D2'])"
    )
    strings: list[StringOverride] = Field(default_factory=list)
    frets: int | None = Field(None, ge=1, le=24, description="number of frets")
    action_nut_m: float | None = Field(None, ge=1e-4, le=3e-3)
    action_12th_m: float | None = Field(None, ge=3e-4, le=8e-3)

    @field_validator("preset")
    @classmethod
    def _known(cls, v: str) -> str:
        if v not in PRESETS:
            raise ValueError(f"unknown preset {v!r}; choose one of {sorted(PRESETS)}")
        return v

    @field_validator("tuning")
    @classmethod
    def _tuning(cls, v: list[str] | None) -> list[str] | None:
        if v is None:
            return v
        for name in v:
            f = note_frequency(name)
            if not 25.0 <= f <= 1400.0:
                raise ValueError(f"pitch {name} = {f:.1f} Hz outside 25..1400 Hz")
        return v


class Output(_Model):
    format: Literal["wav", "flac", "ogg"] = "wav"
    subtype: Literal["PCM_16", "PCM_24", "FLOAT"] = "PCM_16"
    normalize: bool = Field(True, description="scale the peak to -1 dBFS; false: fixed gain")
    pickup_position: float | None = Field(
        None, gt=0.02, lt=0.98, description="where the output is read, x / L (preset default)"
    )


class Scene(_Model):
    duration: float = Field(gt=0.0, le=MAX_DURATION_S, description="seconds")
    sample_rate: int = Field(44100, ge=SAMPLE_RATE_MIN, le=SAMPLE_RATE_MAX, description="Hz")
    guitar: Guitar = Field(default_factory=Guitar)
    events: list[Event] = Field(default_factory=list, max_length=MAX_EVENTS)
    output: Output = Field(default_factory=Output)
    quality: Literal["draft", "standard", "high"] = "standard"
    diagnostics: bool = False

    model_config = ConfigDict(
        json_schema_extra={
            "examples": [
                {
                    "duration": 2.0,
                    "sample_rate": 44100,
                    "guitar": {"preset": "steel-acoustic"},
                    "events": [
                        {"type": "fret", "time": 0.0, "string": 5, "fret": 3, "force": 2.0},
                        {"type": "pluck", "time": 0.05, "string": 5, "position": 0.8,
                         "force": 2.0, "duration": 0.001},
                        {"type": "tap", "time": 1.0, "string": 3, "fret": 7, "force": 0.9},
                    ],
                }
            ]
        }
    )

    @model_validator(mode="after")
    def _consistent(self) -> Scene:
        base = get_preset(self.guitar.preset)
        n = base.n_strings
        if self.guitar.tuning is not None and len(self.guitar.tuning) != n:
            raise ValueError(f"guitar.tuning: {n} notes expected for {base.name}")
        for s in self.guitar.strings:
            if s.string > n:
                raise ValueError(f"guitar.strings: string {s.string} outside 1..{n}")
        preset = self.preset()
        frets = preset.frets
        for i, ev in enumerate(self.events):
            where = f"events[{i}]"
            if ev.string > n:
                raise ValueError(f"{where}.string: {ev.string} outside 1..{n} for {preset.name}")
            if not ev.time < self.duration:
                raise ValueError(f"{where}.time: {ev.time} outside 0 <= time < {self.duration}")
            fret = getattr(ev, "fret", None)
            if fret is not None and fret > frets:
                raise ValueError(f"{where}.fret: {fret} outside 0..{frets} for {preset.name}")
            release = getattr(ev, "release", None)
            if release is not None and not release > ev.time:
                raise ValueError(f"{where}.release: {release} must be after time {ev.time}")
            if isinstance(ev, Pluck) and not math.isfinite(ev.time + ev.duration):
                raise ValueError(f"{where}.duration: not finite")
        return self

    def preset(self) -> Preset:
        """The preset with this scene's overrides applied."""
        return apply_overrides(get_preset(self.guitar.preset), self.guitar)


def parse_scene(scene: Scene | dict) -> Scene:
    return scene if isinstance(scene, Scene) else Scene.model_validate(scene)
