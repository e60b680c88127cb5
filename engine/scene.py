"""The scene: what a user asks the engine to play (the JSON of ``../shared/API.md``).

This pydantic schema is the single definition of valid input for every front end (Python, HTTP, CLI).
Validation happens here, at the edge; the numerical kernels assume valid input and do not check.
Every limit below is a documented range, and every violation is reported with the field's location.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Annotated, Literal, get_args

from pydantic import BaseModel, ConfigDict, Field, field_validator, model_validator

from .effect_specs import MAX_EFFECTS, Effect
from .presets import DEFAULT_PRESET, PRESETS, Preset, apply_overrides, get_preset, note_frequency

# A scene may be as long as a song: it is rendered in blocks, in bounded memory
# (benchmarks/long_song.py); a server sets its own, tighter limits (service/config.py).
MAX_DURATION_S = 1800.0
MAX_EVENTS = 20000  # over all tracks
MAX_TRACKS = 16
MAX_STRINGS = 12
MAX_PLUCK_FORCE_N = 20.0
MAX_FINGER_FORCE_N = 10.0
MAX_TAP_VELOCITY_M_S = 5.0
MAX_BEND_SEMITONES = 3.0  # the grid is made stable for the highest tension a scene reaches
MAX_VIBRATO_CENTS = 100.0  # a string must keep a positive tension this far below its pitch
SAMPLE_RATE_MIN = 22050
SAMPLE_RATE_MAX = 96000
# The latest ``release`` any event may give, s: far past any scene's end (a release after the end
# is the same as none), and small enough that every time becomes a step count the kernels' int64
# arithmetic holds at any internal rate.
MAX_RELEASE_S = 1e6
MAX_STRINGS = 12  # the most strings a guitar (preset or overrides) may have
# the most a nut may be moved towards the frets: a fifth of the shortest nut-to-fret-1 distance of
# the presets (36.2 mm on the 645 mm scale); the presets use at most 3.85 mm (the bass's E1)
MAX_NUT_COMPENSATION_M = 0.007
FLAC_RATE_MAX_ANY = 65535  # FLAC frame headers carry any rate up to this; above, multiples of 10
MAX_NAME_CHARS = 64
# the string models a scene, a track or a live session may ask for, and the quality levels
ModelName = Literal["fdtd", "waveguide"]
MODELS: tuple[str, ...] = get_args(ModelName)
QualityName = Literal["draft", "standard", "high"]


class _Model(BaseModel):
    # strict: JSON types are meant as written (true is not a number, 1.0 is not a string number
    # and "44100" is not a rate); a Python caller passes int and float (numpy scalars: .item()).
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False, strict=True)


Release = Annotated[float | None, Field(gt=0.0, le=MAX_RELEASE_S,
                                        description="time the finger lifts, s")]
Time = Annotated[float, Field(ge=0.0, le=MAX_DURATION_S,
                              description="start time, s (>= 0, < duration)")]
NoteName = Annotated[str, Field(max_length=8)]


Position = Annotated[float, Field(gt=0.0, lt=1.0, description="x / L: 0 at the nut, 1 at the bridge")]


class _Event(_Model):
    time: Time
    string: int = Field(ge=1, le=MAX_STRINGS, description="1 = highest string")


PluckStyle = Literal["finger", "pick", "slap", "pop"]


class Pluck(_Event):
    """A raised-sine force pulse f_e(t) of eq. (5) at ``position`` (paper sec. 2.1).

    ``style`` changes the pulse (``engine.performance.PLUCK_STYLES``): ``finger`` as given; ``pick``
    a 0.3 ms pulse (a plectrum releases the string faster); ``slap`` a 0.5 ms pulse towards the
    fretboard; ``pop`` a 2 ms pull away from it (the string snaps back onto the frets).
    """

    type: Literal["pluck"] = "pluck"
    position: float = Field(0.8, ge=0.02, le=0.98, description="x_e / L")
    force: float = Field(2.0, gt=0.0, le=MAX_PLUCK_FORCE_N, description="peak force f_amp, N")
    duration: float | None = Field(
        None, ge=1e-4, le=0.05, description="pulse length Delta, s (default: the style's)"
    )
    style: PluckStyle = "finger"

    model_config = ConfigDict(
        json_schema_extra={
            "examples": [{"type": "pluck", "time": 0.0, "string": 1, "position": 0.8, "force": 2.0}]
        }
    )


class Fret(_Event):
    """A finger pressed behind fret ``fret`` with ``force`` towards the fretboard (sec. 2.5).

    A force below the string's seating force at that fret (``engine.fd.intonation.seating_force``;
    ``benchmarks/seating.py`` prints 1.08-2.51 N at frets 1, 2, 3, 5 and 12 of the steel preset
    and up to 3.66 N at fret 20) leaves the finger pushing the string down without seating it on the
    fret: a dead or buzzing note.
    """

    type: Literal["fret"] = "fret"
    fret: int = Field(ge=0, le=24, description="0 lifts the finger")
    force: float | None = Field(
        None, gt=0.0, le=MAX_FINGER_FORCE_N,
        description="pressing force, N (default: the preset's, or 1.35 times the seating force "
                    "where the string needs more to rest on the fret)",
    )
    release: Release = None

    model_config = ConfigDict(
        json_schema_extra={"examples": [{"type": "fret", "time": 0.0, "string": 5, "fret": 3}]}
    )


class Tap(_Event):
    """A finger that strikes the string at ``fret`` and stays pressed (paper Fig. 3c)."""

    type: Literal["tap"] = "tap"
    fret: int = Field(ge=1, le=24)
    force: float | None = Field(
        None, gt=0.0, le=MAX_FINGER_FORCE_N,
        description="pressing force, N (default: the preset's, or 1.35 times the seating force "
                    "where the string needs more to rest on the fret)",
    )
    velocity: float = Field(
        1.0, gt=0.0, le=MAX_TAP_VELOCITY_M_S, description="speed towards the fretboard, m/s"
    )
    release: Release = None

    model_config = ConfigDict(
        json_schema_extra={"examples": [{"type": "tap", "time": 0.0, "string": 3, "fret": 7}]}
    )


class HammerOn(Tap):
    """A tap on a sounding string that leaves any other finger on the string where it is."""

    type: Literal["hammer_on"] = "hammer_on"
    velocity: float = Field(
        2.0, gt=0.0, le=MAX_TAP_VELOCITY_M_S, description="speed towards the fretboard, m/s"
    )

    model_config = ConfigDict(
        json_schema_extra={"examples": [{"type": "hammer_on", "time": 0.5, "string": 3, "fret": 7}]}
    )


class PullOff(_Event):
    """The finger on ``fret`` leaves the string, plucking it with ``force`` as it goes; any lower
    fret still held (or the open string) sounds."""

    type: Literal["pull_off"] = "pull_off"
    fret: int = Field(ge=1, le=24)
    force: float = Field(1.0, gt=0.0, le=MAX_PLUCK_FORCE_N, description="pluck as it leaves, N")

    model_config = ConfigDict(
        json_schema_extra={"examples": [{"type": "pull_off", "time": 1.0, "string": 3, "fret": 7}]}
    )


class Slide(_Event):
    """The fretting finger glides from ``from_fret`` to ``to_fret`` over ``duration`` while
    pressing with ``force`` (the finger position x_FG moves, paper sec. 2.5)."""

    type: Literal["slide"] = "slide"
    from_fret: int = Field(ge=1, le=24)
    to_fret: int = Field(ge=1, le=24)
    duration: float = Field(0.15, gt=0.0, le=10.0, description="glide time, s")
    force: float | None = Field(
        None, gt=0.0, le=MAX_FINGER_FORCE_N,
        description="pressing force, N (default: the preset's, or 1.35 times the seating force "
                    "where the string needs more to rest on the fret)",
    )
    release: Release = None

    model_config = ConfigDict(
        json_schema_extra={"examples": [{"type": "slide", "time": 0.5, "string": 3,
                                         "from_fret": 5, "to_fret": 7, "duration": 0.2}]}
    )


class Bend(_Event):
    """Raise the pitch by ``semitones`` over ``duration`` (by raising the tension), hold it until
    ``release``, then return over ``duration``."""

    type: Literal["bend"] = "bend"
    semitones: float = Field(gt=0.0, le=MAX_BEND_SEMITONES, description="pitch rise")
    duration: float = Field(0.15, gt=0.0, le=10.0, description="rise (and return) time, s")
    release: float | None = Field(None, gt=0.0, le=MAX_RELEASE_S,
                                  description="time the bend starts back, s")

    model_config = ConfigDict(
        json_schema_extra={"examples": [{"type": "bend", "time": 0.3, "string": 2,
                                         "semitones": 2.0, "duration": 0.2}]}
    )


class Vibrato(_Event):
    """Pitch oscillation of ``depth_cents`` (peak) at ``rate_hz`` for ``duration`` seconds."""

    type: Literal["vibrato"] = "vibrato"
    depth_cents: float = Field(20.0, gt=0.0, le=MAX_VIBRATO_CENTS)
    rate_hz: float = Field(5.5, ge=0.5, le=15.0)
    duration: float = Field(1.0, gt=0.0, le=MAX_DURATION_S)

    model_config = ConfigDict(
        json_schema_extra={"examples": [{"type": "vibrato", "time": 0.5, "string": 1,
                                         "depth_cents": 25, "rate_hz": 5.5, "duration": 1.0}]}
    )


class Harmonic(_Event):
    """A light, lossy touch (no pressing force) at ``fret`` or ``position``: with a pluck it
    sounds the natural harmonic whose node is at the touch point."""

    type: Literal["harmonic"] = "harmonic"
    fret: int | None = Field(None, ge=1, le=24, description="touch over this fret")
    position: float | None = Field(None, gt=0.02, lt=0.98, description="or at x / L")
    release: Release = None

    model_config = ConfigDict(
        json_schema_extra={"examples": [{"type": "harmonic", "time": 0.0, "string": 1,
                                         "fret": 12, "release": 0.3}]}
    )

    @model_validator(mode="after")
    def _one_place(self) -> Harmonic:
        if (self.fret is None) == (self.position is None):
            raise ValueError("harmonic: give exactly one of fret or position")
        return self


class Mute(_Model):
    """A palm resting near the bridge: lossy contact over a few centimetres."""

    type: Literal["mute"] = "mute"
    time: Time
    string: int | None = Field(None, ge=1, le=MAX_STRINGS, description="omit to mute every string")
    position: float = Field(0.96, ge=0.7, le=0.99, description="palm centre, x / L")
    amount: float = Field(0.7, ge=0.0, le=1.0, description="0 barely touching .. 1 firm")
    release: float | None = Field(None, gt=0.0, le=MAX_RELEASE_S,
                                  description="time the palm lifts, s")

    model_config = ConfigDict(
        json_schema_extra={"examples": [{"type": "mute", "time": 0.0, "amount": 0.8}]}
    )


class Strum(_Model):
    """Plucks across ``strings`` (default all), low to high for ``down``, spread over ``spread``."""

    type: Literal["strum"] = "strum"
    time: float = Field(ge=0.0, le=MAX_DURATION_S, description="first pluck, s (>= 0, < duration)")
    strings: list[int] | None = Field(None, max_length=MAX_STRINGS,
                                      description="default: all strings; each at most once")
    direction: Literal["down", "up"] = "down"
    spread: float = Field(0.03, ge=0.0, le=1.0, description="first to last pluck, s")
    force: float = Field(2.0, gt=0.0, le=MAX_PLUCK_FORCE_N, description="peak force, N")
    position: float = Field(0.8, ge=0.02, le=0.98, description="x / L")
    style: PluckStyle = "finger"

    model_config = ConfigDict(
        json_schema_extra={"examples": [{"type": "strum", "time": 0.0, "direction": "down"}]}
    )

    @field_validator("strings")
    @classmethod
    def _strings(cls, v: list[int] | None) -> list[int] | None:
        if v is not None and (not v or any(not 1 <= s <= MAX_STRINGS for s in v)):
            raise ValueError(f"strings: a non-empty list of string numbers 1..{MAX_STRINGS}")
        if v is not None and len(set(v)) != len(v):
            raise ValueError("strings: each string at most once")
        return v


class Damp(_Model):
    """The player stops the string: the fretting finger relaxes onto it (or, on an open string, a
    hand touches it) and the note dies, until the string's next event.  Modelled as the relaxed
    hand's fingertips resting on the string (``engine.performance.DAMP_*``: point dampers from where
    the finger was, or from over fret 5 on an open string), any fretting finger lifted;
    docs/engine.md gives the decay times (13-70 ms to -60 dB on the steel preset)."""

    type: Literal["damp"] = "damp"
    time: float = Field(ge=0.0, description="start time, s (>= 0, < duration)")
    string: int | None = Field(None, ge=1, le=MAX_STRINGS, description="omit to damp every string")

    model_config = ConfigDict(
        json_schema_extra={"examples": [{"type": "damp", "time": 1.0, "string": 6}]}
    )


Event = Annotated[
    Pluck | Fret | Tap | HammerOn | PullOff | Slide | Bend | Vibrato | Harmonic | Mute | Strum
    | Damp,
    Field(discriminator="type"),
]


class StringOverride(_Model):
    """Per-string physical overrides of a preset; omitted fields keep the preset's value."""

    string: int = Field(ge=1, le=MAX_STRINGS)
    note: NoteName | None = Field(None, description="open-string pitch, e.g. 'D2'")
    radius_m: float | None = Field(None, ge=5e-5, le=2e-3)
    density_kg_m3: float | None = Field(None, ge=500.0, le=25000.0)
    youngs_modulus_pa: float | None = Field(None, ge=1e8, le=4e11)
    t60_fundamental_s: float | None = Field(None, ge=0.05, le=60.0)
    t60_2khz_s: float | None = Field(None, ge=0.02, le=60.0)
    saddle_setback_m: float | None = Field(
        None, ge=0.0, le=0.02, description="intonation compensation: length beyond the scale, m"
    )
    nut_compensation_m: float | None = Field(
        None, ge=0.0, le=MAX_NUT_COMPENSATION_M,
        description="intonation compensation: the nut moved this far towards the frets, m (the "
                    "open string is that much shorter, the frets stay where the scale puts them)"
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
    preset: str = Field(DEFAULT_PRESET, max_length=MAX_NAME_CHARS,
                        description=f"one of {sorted(PRESETS)}")
    tuning: list[NoteName] | None = Field(
        None, min_length=1, max_length=MAX_STRINGS,
        description="open-string notes, string 1 first (e.g. ['D4','B3','G3','D3','G2','D2']); more "
                    "notes than the preset has strings add strings on the low side, built like the "
                    "preset's lowest (engine.presets.extend_preset); fewer keep the preset's "
                    "strings nearest in pitch (engine.presets.fit_strings)"
    )
    strings: list[StringOverride] = Field(default_factory=list, max_length=MAX_STRINGS)
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


class Pickup(_Model):
    position: float = Field(gt=0.02, lt=0.98, description="x / L")
    gain: float = Field(1.0, ge=0.0, le=10.0)


class Output(_Model):
    format: Literal["wav", "flac", "ogg"] = "wav"
    subtype: Literal["PCM_16", "PCM_24", "FLOAT"] = "PCM_16"
    normalize: bool = Field(True, description="scale the peak to -1 dBFS; false: fixed gain")
    pickup_position: float | None = Field(
        None, gt=0.02, lt=0.98, description="where the output is read, x / L (preset default)"
    )
    pickups: list[Pickup] | None = Field(
        None, min_length=1, max_length=4,
        description="several pickups mixed (overrides pickup_position)",
    )
    # an int in 1..2 rather than Literal[1, 2], which would take true and 2.0 for 1 and 2
    channels: int = Field(1, ge=1, le=2, description="1: mono; 2: stereo, each string panned")
    pan: list[float] | None = Field(
        None, max_length=MAX_STRINGS,
        description="per string, -1 left .. 1 right (default: low strings left)"
    )
    body: Literal["none", "acoustic", "classical"] | None = Field(
        None, description="body response (default: the preset's)"
    )
    stems: bool = Field(
        False, description="also each string's signal before body, pan, effects and mix, at the "
                           "mix's gain (summed: the dry mix); docs/service.md says how it comes")

    @field_validator("pan")
    @classmethod
    def _pan(cls, v: list[float] | None) -> list[float] | None:
        if v is not None and any(not -1.0 <= p <= 1.0 for p in v):
            raise ValueError("pan: values in -1..1")
        return v


# --- Several instruments in one scene (API.md): a track is one instrument with its own events,
# level, place in the stereo field and effects chain.


class Track(_Model):
    """One instrument of a scene: its strings are independent of the other tracks'; its output
    goes through ``effects`` in order, then ``gain_db``, and is mixed with the others."""

    name: str = Field("", max_length=100, description="a label (labels, warnings)")
    guitar: Guitar = Field(default_factory=Guitar)
    events: list[Event] = Field(default_factory=list, max_length=MAX_EVENTS)
    gain_db: float = Field(0.0, ge=-60.0, le=24.0, description="track level after its effects, dB")
    pan: float | None = Field(
        None, ge=-1.0, le=1.0,
        description="stereo place of the whole track, -1 left .. 1 right (constant power); "
                    "omitted: its strings spread as a single guitar's (low strings left)")
    effects: list[Effect] = Field(default_factory=list, max_length=MAX_EFFECTS,
                                  description="effects chain, in order (engine.effect_specs)")
    model: ModelName | None = Field(
        None, description="the string model of this track (omitted: the scene's ``model``)")

    model_config = ConfigDict(
        json_schema_extra={"examples": [{
            "name": "Rhythm", "guitar": {"preset": "electric"}, "gain_db": -3.0, "pan": -0.4,
            "events": [{"type": "strum", "time": 0.0}],
            "effects": [{"type": "drive", "gain_db": 18}, {"type": "reverb", "room_size": 0.4}]}]}
    )

    def preset(self) -> Preset:
        """The track's preset with its overrides (and extra strings) applied."""
        return apply_overrides(get_preset(self.guitar.preset), self.guitar)


@dataclass(frozen=True)
class Stem:
    """One column of a render's stems: ``track`` (0-based, in the scene's order), its ``name``
    (``""`` when unnamed) and the ``string`` (1 = highest, as the scene numbers strings)."""

    track: int
    name: str
    string: int

    @property
    def label(self) -> str:
        """``t1-s6``: a stem's file name without its suffix (the front ends')."""
        return f"t{self.track + 1}-s{self.string}"


def stems_index(layout: list[Stem], suffix: str, sample_rate: int, gain: float,
                clipped: int = 0) -> dict:
    """``stems.json`` of the front ends: the stems' files in the labels' order (``annotation``:
    the index of the string's ``note_midi`` annotation in the scene's labels) and the ``gain``
    (samples per m/s) they share with the mix."""
    return {
        "sample_rate": sample_rate,
        "gain": gain,
        "clipped_samples": clipped,
        "about": "each string's pickup velocity before pan, body and effects, times its track's "
                 "gain_db and this gain (the mix's): summed, the dry mix",
        "stems": [{"file": f"{s.label}.{suffix}", "track": s.track,
                   "track_name": s.name or f"track {s.track + 1}", "string": s.string,
                   "annotation": k} for k, s in enumerate(layout)],
    }


# --- What a converted score says beyond its events (the labels read it; rendering ignores it).

MAX_SCORE_MARKS = 100_000  # bars, beats, tempo changes, keys or chords of one scene


class TempoMark(_Model):
    time: Time
    bpm: float = Field(gt=0.0, le=20000.0, description="quarter notes per minute, as played")


class LabelMark(_Model):
    time: Time
    value: str = Field(max_length=40, description="key as 'E:minor'; chord as 'A:min7' (JAMS)")


class ScoreInfo(_Model):
    """The score a scene was converted from (``engine.score_to_scene`` writes it): its title, and
    its bars and beats in seconds as played (repeats unfolded, the tempo map and tempo scale
    applied, cut where the scene is).  ``bars[i]`` starts the score's bar ``bar_numbers[i]``;
    ``beat_positions[i]`` is beat ``beats[i]``'s place in its bar, 1 = the downbeat (a dotted
    beat in 6/8, 9/8, 12/8).  The labels' ``beat``, ``tempo``, ``key_mode`` and ``chord``
    annotations come from here; the renderer ignores it."""

    title: str = Field("", max_length=300)
    artist: str = Field("", max_length=300)
    source: str = Field("", max_length=300, description="the score file's name")
    format: str = Field("", max_length=16, description="gp, gpx, gp7, musicxml or midi")
    bars: list[Time] = Field(default_factory=list, max_length=MAX_SCORE_MARKS)
    bar_numbers: list[int] = Field(default_factory=list, max_length=MAX_SCORE_MARKS)
    beats: list[Time] = Field(default_factory=list, max_length=MAX_SCORE_MARKS)
    beat_positions: list[int] = Field(default_factory=list, max_length=MAX_SCORE_MARKS)
    tempo: list[TempoMark] = Field(default_factory=list, max_length=MAX_SCORE_MARKS)
    keys: list[LabelMark] = Field(default_factory=list, max_length=MAX_SCORE_MARKS)
    chords: list[LabelMark] = Field(default_factory=list, max_length=MAX_SCORE_MARKS)

    @model_validator(mode="after")
    def _parallel(self) -> ScoreInfo:
        if len(self.bar_numbers) != len(self.bars):
            raise ValueError("score.bar_numbers: one per bar")
        if len(self.beat_positions) != len(self.beats):
            raise ValueError("score.beat_positions: one per beat")
        return self


class Scene(_Model):
    duration: float = Field(gt=0.0, le=MAX_DURATION_S, description="seconds")
    sample_rate: int = Field(44100, ge=SAMPLE_RATE_MIN, le=SAMPLE_RATE_MAX, description="Hz")
    guitar: Guitar = Field(default_factory=Guitar)
    events: list[Event] = Field(default_factory=list, max_length=MAX_EVENTS)
    tracks: list[Track] | None = Field(
        None, min_length=1, max_length=MAX_TRACKS,
        description="several instruments (instead of guitar and events); see Track")
    output: Output = Field(default_factory=Output)
    quality: QualityName = "standard"
    model: ModelName = Field(
        "fdtd",
        description="fdtd: the DAFx24 finite-difference string (default); waveguide: the digital "
                    "waveguide of Evangelista & Eckerholm 2010, many times cheaper, driven by the "
                    "same events (engine/waveguide)",
    )
    diagnostics: bool = False
    score: ScoreInfo | None = Field(
        None, description="the score the scene was converted from: title, bars, beats, tempo, "
                          "keys and chords in seconds (labels read it; rendering ignores it)")

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
        if round(self.duration * self.sample_rate) < 1:
            raise ValueError(f"duration: {self.duration:g} s is shorter than one sample at "
                             f"{self.sample_rate} Hz (at least {1.0 / self.sample_rate:.3g} s)")
        if (self.output.format == "flac" and self.sample_rate > FLAC_RATE_MAX_ANY
                and self.sample_rate % 10):
            raise ValueError(
                f"sample_rate: FLAC carries rates above {FLAC_RATE_MAX_ANY} Hz in steps of 10 Hz "
                f"only; {self.sample_rate} is not one (allowed for flac: "
                f"{SAMPLE_RATE_MIN}..{FLAC_RATE_MAX_ANY}, or a multiple of 10 up to "
                f"{SAMPLE_RATE_MAX}; wav and ogg take any rate)")
        if self.tracks is None:
            _check_instrument(self.guitar, self.events, self.duration, "", self.output.pan)
            return self
        if self.events or "guitar" in self.model_fields_set:
            raise ValueError("tracks: give either tracks or top-level guitar/events, not both")
        if self.output.pan is not None:
            raise ValueError("output.pan: per-string pan is for a single guitar; "
                             "with tracks use tracks[i].pan")
        total = sum(len(t.events) for t in self.tracks)
        if total > MAX_EVENTS:
            raise ValueError(f"tracks: {total} events over all tracks, at most {MAX_EVENTS}")
        for i, t in enumerate(self.tracks):
            _check_instrument(t.guitar, t.events, self.duration, f"tracks[{i}].", None)
        return self

    def preset(self) -> Preset:
        """The preset with this scene's overrides applied (of a scene without ``tracks``)."""
        return apply_overrides(get_preset(self.guitar.preset), self.guitar)

    def instruments(self) -> list[Track]:
        """The scene's tracks; a scene with top-level ``guitar``/``events`` is one track of them
        (its pan None: strings spread as ``output.pan`` says)."""
        if self.tracks is not None:
            return list(self.tracks)
        return [Track(guitar=self.guitar, events=self.events)]

    def track_scenes(self) -> list[Scene]:
        """One single-instrument scene per track (the same duration, rate, output, quality and
        diagnostics; no ``output.pan``), which ``engine.fd.instrument.prepare`` renders.  A scene without
        ``tracks`` is its own only one."""
        if self.tracks is None:
            return [self]
        return [self.model_copy(update={"guitar": t.guitar, "events": t.events, "tracks": None,
                                        "model": t.model or self.model})
                for t in self.tracks]

    def track_label(self, i: int) -> str:
        """How warnings name track ``i``: ``track 1 'Rhythm'`` (empty for a single guitar)."""
        if self.tracks is None:
            return ""
        name = self.tracks[i].name
        return f"track {i + 1}" + (f" {name!r}" if name else "")

    def stems(self) -> list[Stem]:
        """What each column of a render's stems holds (``engine.mix``): every string of every
        track, track by track, the lowest string first (the labels' order, and their name of a
        lone guitar)."""
        return [Stem(i, track.name if self.tracks is not None else "guitar", n - k)
                for i, track in enumerate(self.instruments())
                for n in (track.preset().n_strings,) for k in range(n)]

    def event_count(self) -> int:
        """Events over all tracks (what ``MAX_EVENTS`` and a server's limit count)."""
        return sum(len(t.events) for t in self.instruments())


def _check_instrument(guitar: Guitar, events: list, duration: float, where: str,
                      pan: list[float] | None) -> None:
    """Cross-field limits of one instrument: its overrides, its events' strings, times and
    frets against its preset.  ``where`` prefixes every field name (``tracks[i].``)."""
    base = get_preset(guitar.preset)
    for s in guitar.strings:
        n_tuned = len(guitar.tuning) if guitar.tuning is not None else base.n_strings
        if s.string > n_tuned:
            raise ValueError(f"{where}guitar.strings: string {s.string} outside 1..{n_tuned}")
    preset = apply_overrides(base, guitar)
    n = preset.n_strings
    _playable(guitar, preset, where)
    frets = preset.frets
    if pan is not None and len(pan) != n:
        raise ValueError(f"output.pan: {n} values expected for {preset.name}")
    for i, ev in enumerate(events):
        at = f"{where}events[{i}]"
        fields = ev.__dict__  # an event's fields (a missing one through getattr costs 5 us)
        single = fields.get("string")
        if single is not None and single > n:
            raise ValueError(f"{at}.string: {single} outside 1..{n} for {preset.name}")
        for j, st in enumerate(fields.get("strings") or []):
            if st > n:
                raise ValueError(f"{at}.strings[{j}]: {st} outside 1..{n} for {preset.name}")
        if not ev.time < duration:
            raise ValueError(f"{at}.time: {ev.time} outside 0 <= time < {duration}")
        for name in ("fret", "from_fret", "to_fret"):
            fret = fields.get(name)
            if fret is not None and fret > frets:
                raise ValueError(f"{at}.{name}: {fret} outside 0..{frets} for {preset.name}")
        release = fields.get("release")
        if release is not None and not release > ev.time:
            raise ValueError(f"{at}.release: {release} must be after time {ev.time}")


def _playable(g: Guitar, preset: Preset, where: str = "") -> None:
    """Cross-field limits of the physical overrides: a string's rest line must clear the fret
    tips, and every string needs a positive tension at every pitch a scene can ask of it."""
    if preset.action_12th_m < preset.action_nut_m:
        # the rest line would fall towards the body and run into the upper frets
        name = "action_12th_m" if g.action_12th_m is not None else "action_nut_m"
        raise ValueError(
            f"{where}guitar.{name}: action_12th_m {preset.action_12th_m:g} m is below action_nut_m "
            f"{preset.action_nut_m:g} m; the string must rise from the nut towards the body "
            "(action_12th_m >= action_nut_m) or it starts below the fret tips")
    # Stiff string: f1^2 4 L^2 rho A = T + pi^2 E I / L^2.  The stiffness term must stay below
    # the pitch's at the lowest pitch a vibrato reaches, or no positive tension tunes it.
    low = 2.0 ** (-2.0 * MAX_VIBRATO_CENTS / 1200.0)
    for i, spec in enumerate(preset.strings, start=1):
        length = preset.string_length_m(i)
        stiff = spec.stiffness_tension_n(length)
        limit = low * spec.pitch_tension_n(length)
        if stiff < limit:
            continue
        # the field that made it so: the string's override, else a lowered tuning
        at = next((f"guitar.strings[{j}].youngs_modulus_pa" for j, o in enumerate(g.strings)
                   if o.string == i), f"guitar.tuning[{i - 1}]")
        raise ValueError(
            f"{where}{at}: string {i} ({spec.note}) is too stiff for its pitch: "
            f"its bending stiffness pi^2 E I / L^2 = {stiff:.3g} N must be below "
            f"4 L^2 rho A f0^2 x 2^(-1/6) = {limit:.3g} N (a positive tension down to a "
            f"{MAX_VIBRATO_CENTS:g}-cent vibrato); with this radius_m, density_kg_m3 and note "
            f"youngs_modulus_pa must be below {spec.youngs_modulus_pa * limit / stiff:.3g} Pa "
            "(or lower radius_m, raise density_kg_m3 or the note)")


def parse_scene(scene: Scene | dict) -> Scene:
    return scene if isinstance(scene, Scene) else Scene.model_validate(scene)


def frame_count(scene: Scene | dict) -> int:
    """The number of output frames ``engine.render`` (and ``engine.blocks``, concatenated) returns
    for a scene: its duration at its rate, rounded.  Known before anything is simulated (a
    stream's WAV header needs it)."""
    sc = parse_scene(scene)
    return int(round(sc.duration * sc.sample_rate))
