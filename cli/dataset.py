"""Dataset specs: scenes drawn from seeded random choices, for ``guitar-synth batch``.

A spec is a YAML or JSON file whose top level is ``dataset:``::

    dataset:
      name: chords-and-lines
      seed: 7
      count: 200
      duration: [3, 6]                 # seconds, drawn uniformly
      presets: [steel-acoustic, nylon-classical, electric]
      tunings: [standard, drop-d]      # or a list of note names, string 1 first
      content: {chords: 2, melody: 1}  # relative weights
      tempo_bpm: [70, 140]
      articulations: [hammer_on, pull_off, slide, bend, vibrato, harmonic, mute]
      articulation_rate: 0.3           # share of melody notes with one articulation
      pluck_force_n: [0.8, 3.0]
      finger_force_n: [2.5, 4.0]
      styles: [finger, pick]
      pickup: [0.75, 0.95]             # x / L, or leave out for the preset's
      bodies: [default]                # default (the preset's), none, acoustic, classical
      qualities: [draft]
      models: [fdtd]                   # fdtd (finite differences) and/or waveguide
      sample_rate: 44100

Item ``i`` is drawn from ``numpy.random.default_rng([seed, i])``: it depends on the spec, the seed
and its index only, so the same spec gives the same scenes (and the engine the same audio, bit for
bit) in any order, on any worker, and an item can be redone alone.  Unknown keys and impossible
ranges are refused by the pydantic model with the field named.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Literal

import numpy as np
from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

import engine
from engine import PRESETS, ModelName


def _maximum(node: dict) -> float:
    """The ``maximum`` of a number field of the scene's JSON schema (an optional one: anyOf)."""
    for option in [node, *node.get("anyOf", [])]:
        if "maximum" in option:
            return float(option["maximum"])
    raise KeyError("maximum")


# The scene schema's own limits (the command knows the engine by its public names only).
_SCHEMA = engine.Scene.model_json_schema()
MAX_DURATION_S = _maximum(_SCHEMA["properties"]["duration"])
MAX_PLUCK_FORCE_N = _maximum(_SCHEMA["$defs"]["Pluck"]["properties"]["force"])
MAX_FINGER_FORCE_N = _maximum(_SCHEMA["$defs"]["Fret"]["properties"]["force"])
_NAMES = ("C", "C#", "D", "D#", "E", "F", "F#", "G", "G#", "A", "A#", "B")
_FLATS = {"Db": "C#", "Eb": "D#", "Gb": "F#", "Ab": "G#", "Bb": "A#"}


def note_midi(note: str) -> int:
    """MIDI number of a note name in scientific pitch (E2 = 40, A4 = 69)."""
    text = note.strip()
    written = text[:2] if len(text) > 2 and text[1] in "#b" else text[:1]
    name = _FLATS.get(written, written)
    try:
        octave = int(text[len(written):])
    except ValueError:
        octave = None
    if name not in _NAMES or octave is None:
        raise ValueError(f"{note!r} is not a note name like E2")
    return _NAMES.index(name) + 12 * (octave + 1)

ARTICULATIONS = ("hammer_on", "pull_off", "slide", "bend", "vibrato", "harmonic", "mute")
NAMED_TUNINGS = ("standard", "drop-d", "half-step-down")

# Open chord shapes, frets of strings 6..1 (None: not played), for six-string presets.
CHORDS = {
    "C": (None, 3, 2, 0, 1, 0), "G": (3, 2, 0, 0, 0, 3), "D": (None, None, 0, 2, 3, 2),
    "A": (None, 0, 2, 2, 2, 0), "E": (0, 2, 2, 1, 0, 0), "Am": (None, 0, 2, 2, 1, 0),
    "Em": (0, 2, 2, 0, 0, 0), "Dm": (None, None, 0, 2, 3, 1), "A7": (None, 0, 2, 0, 2, 0),
    "E7": (0, 2, 0, 1, 0, 0),
}


class SpecError(ValueError):
    """A spec that cannot be used; the message is one line naming the field."""


def _range(lo: float, hi: float):
    def check(v: tuple[float, float]) -> tuple[float, float]:
        a, b = v
        if a > b:
            raise ValueError(f"low {a:g} is above high {b:g}")
        if a < lo or b > hi:
            raise ValueError(f"must lie within [{lo:g}, {hi:g}], got [{a:g}, {b:g}]")
        return v
    return check


class Spec(BaseModel):
    model_config = ConfigDict(extra="forbid")

    name: str = Field("dataset", pattern=r"^[A-Za-z0-9_.-]{1,64}$")
    seed: int = Field(0, ge=0, le=2**63 - 1)
    count: int = Field(ge=1, le=10_000_000)
    duration: tuple[float, float] = (2.0, 4.0)
    presets: list[str] = Field(["steel-acoustic"], min_length=1)
    tunings: list[str | list[str]] = Field(["standard"], min_length=1)
    content: dict[Literal["chords", "melody"], float] = {"chords": 1.0, "melody": 1.0}
    tempo_bpm: tuple[float, float] = (70.0, 140.0)
    articulations: list[Literal[ARTICULATIONS]] = list(ARTICULATIONS)  # type: ignore[valid-type]
    articulation_rate: float = Field(0.3, ge=0.0, le=1.0)
    pluck_force_n: tuple[float, float] = (0.8, 3.0)
    finger_force_n: tuple[float, float] = (2.5, 4.0)
    styles: list[Literal["finger", "pick", "slap", "pop"]] = Field(["finger", "pick"],
                                                                   min_length=1)
    pickup: tuple[float, float] | None = None
    bodies: list[Literal["default", "none", "acoustic", "classical"]] = Field(["default"],
                                                                              min_length=1)
    qualities: list[Literal["draft", "standard", "high"]] = Field(["draft"], min_length=1)
    models: list[ModelName] = Field(["fdtd"], min_length=1)
    sample_rate: int = Field(44100, ge=22050, le=96000)
    format: Literal["wav", "flac"] = "wav"

    _duration = field_validator("duration")(_range(1e-3, MAX_DURATION_S))
    _tempo = field_validator("tempo_bpm")(_range(20.0, 400.0))
    _pluck = field_validator("pluck_force_n")(_range(1e-3, MAX_PLUCK_FORCE_N))
    _finger = field_validator("finger_force_n")(_range(1e-3, MAX_FINGER_FORCE_N))

    @field_validator("pickup")
    @classmethod
    def _pickup(cls, v: tuple[float, float] | None) -> tuple[float, float] | None:
        return v if v is None else _range(0.03, 0.97)(v)

    @field_validator("presets")
    @classmethod
    def _presets(cls, v: list[str]) -> list[str]:
        unknown = [p for p in v if p not in PRESETS]
        if unknown:
            raise ValueError(f"unknown {unknown}; known: {sorted(PRESETS)}")
        return v

    @field_validator("tunings")
    @classmethod
    def _tunings(cls, v: list[str | list[str]]) -> list[str | list[str]]:
        for t in v:
            if isinstance(t, str):
                if t not in NAMED_TUNINGS:
                    raise ValueError(f"{t!r} is not one of {list(NAMED_TUNINGS)} or a list of "
                                     "notes")
            else:
                for note in t:
                    f = 440.0 * 2 ** ((note_midi(note) - 69) / 12)
                    if not 25.0 <= f <= 1400.0:
                        raise ValueError(f"{note} = {f:.1f} Hz outside 25..1400 Hz")
        return v

    @field_validator("content")
    @classmethod
    def _content(cls, v: dict[str, float]) -> dict[str, float]:
        if any(w < 0 for w in v.values()) or sum(v.values()) <= 0:
            raise ValueError("weights must be >= 0 with a positive sum")
        return v

    @model_validator(mode="after")
    def _articulations(self) -> Spec:
        if self.articulation_rate > 0 and not self.articulations:
            raise ValueError("articulation_rate > 0 needs at least one articulation")
        return self


def is_spec(path: Path) -> bool:
    """A YAML file, or a JSON file whose top level has ``dataset``."""
    if path.suffix.lower() in (".yaml", ".yml"):
        return True
    if path.suffix.lower() == ".json":
        try:
            with open(path, "rb") as f:
                head = f.read(4096)
        except OSError:
            return False
        return head.lstrip().startswith(b"{") and b'"dataset"' in head.split(b",")[0]
    return False


def load_spec(path: Path) -> Spec:
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise SpecError(f"{path}: cannot read: {exc}") from None
    try:
        if path.suffix.lower() == ".json":
            data = json.loads(text)
        else:
            import yaml

            data = yaml.safe_load(text)
    except Exception as exc:
        first = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise SpecError(f"{path}: not valid {path.suffix[1:].upper()}: {first}") from None
    if not isinstance(data, dict) or set(data) != {"dataset"} or not isinstance(
            data["dataset"], dict):
        raise SpecError(f"{path}: a spec is a mapping with one key, 'dataset'")
    try:
        return Spec.model_validate(data["dataset"])
    except ValidationError as exc:
        e = exc.errors()[0]
        where = ".".join(str(p) for p in ("dataset", *e["loc"]))
        more = f" (and {len(exc.errors()) - 1} more)" if len(exc.errors()) > 1 else ""
        msg = e["msg"].removeprefix("Value error, ")
        if e["type"] == "extra_forbidden":
            msg = f"unknown key; allowed: {sorted(Spec.model_fields)}"
        raise SpecError(f"{path}: {where}: {msg}{more}") from None


# ---- drawing scenes ---------------------------------------------------------------------------


def _tuning(name: str | list[str], preset: str) -> list[str] | None:
    if not isinstance(name, str):
        return list(name)
    if name == "standard":
        return None
    notes = [s.note for s in PRESETS[preset].strings]
    if name == "drop-d":
        notes[-1] = _shift(notes[-1], -2)
    elif name == "half-step-down":
        notes = [_shift(n, -1) for n in notes]
    return notes


def _shift(note: str, semitones: int) -> str:
    midi = note_midi(note) + semitones
    return f"{_NAMES[midi % 12]}{midi // 12 - 1}"


def draw_scene(spec: Spec, index: int) -> dict[str, Any]:
    """Scene ``index`` of the spec (a dict in the JSON form)."""
    rng = np.random.default_rng([spec.seed, index])

    def pick(seq):
        return seq[int(rng.integers(len(seq)))]

    def uniform(r: tuple[float, float]) -> float:
        return float(rng.uniform(r[0], r[1])) if r[1] > r[0] else float(r[0])

    preset = pick(spec.presets)
    p = PRESETS[preset]
    n = p.n_strings
    duration = round(uniform(spec.duration), 3)
    beat = 60.0 / uniform(spec.tempo_bpm)
    kinds = [k for k, w in spec.content.items() if w > 0]
    weights = np.array([spec.content[k] for k in kinds], dtype=float)
    kind = kinds[int(rng.choice(len(kinds), p=weights / weights.sum()))]
    if kind == "chords" and n != 6:
        kind = "melody"  # the chord shapes are six-string shapes
    style = pick(spec.styles)
    events = (_chords if kind == "chords" else _melody)(spec, rng, p, duration, beat, style)
    guitar: dict[str, Any] = {"preset": preset}
    tuning = _tuning(pick(spec.tunings), preset)
    if tuning is not None:
        guitar["tuning"] = tuning
    output: dict[str, Any] = {"format": spec.format}
    if spec.pickup is not None:
        output["pickup_position"] = round(uniform(spec.pickup), 4)
    body = pick(spec.bodies)
    if body != "default":
        output["body"] = body
    scene = {"duration": duration, "sample_rate": spec.sample_rate, "guitar": guitar,
             "quality": pick(spec.qualities), "events": events, "output": output}
    # drawn last, and only from a choice: a spec without models draws what it drew before
    model = pick(spec.models) if len(spec.models) > 1 else spec.models[0]
    if model != engine.Scene.model_fields["model"].default:  # the schema's default stays implicit
        scene["model"] = model
    return scene


def _r(x: float) -> float:
    return round(float(x), 4)


def _chords(spec: Spec, rng, p, duration: float, beat: float, style: str) -> list[dict]:
    events: list[dict] = []
    t = 0.0
    names = list(CHORDS)
    while t < duration - 0.05:
        shape = CHORDS[names[int(rng.integers(len(names)))]]
        strings = [6 - i for i, f in enumerate(shape) if f is not None]
        for i, f in enumerate(shape):
            if f:  # fretted strings; open and unplayed strings need no finger
                events.append({"type": "fret", "time": _r(t), "string": 6 - i, "fret": f,
                               "force": _r(rng.uniform(*spec.finger_force_n))})
        span = 2 * beat
        for k in range(2):
            ts = t + 0.01 + k * beat
            if ts >= duration - 0.01:
                break
            events.append({"type": "strum", "time": _r(ts), "strings": strings,
                           "direction": "down" if k == 0 else "up",
                           "spread": _r(rng.uniform(0.015, 0.04)),
                           "force": _r(rng.uniform(*spec.pluck_force_n)), "style": style})
        t += span
    return events


def _melody(spec: Spec, rng, p, duration: float, beat: float, style: str) -> list[dict]:
    events: list[dict] = []
    n, top = p.n_strings, min(p.frets, 12)
    step = beat / float(rng.choice([1, 2]))
    t = 0.0
    string, fret = int(rng.integers(1, n + 1)), int(rng.integers(0, 8))
    while t < duration - 0.05:
        string = int(np.clip(string + rng.integers(-1, 2), 1, n))
        fret = int(np.clip(fret + rng.integers(-2, 3), 0, top - 2))
        force = _r(rng.uniform(*spec.pluck_force_n))
        press = _r(rng.uniform(*spec.finger_force_n))
        art = (spec.articulations[int(rng.integers(len(spec.articulations)))]
               if rng.random() < spec.articulation_rate else None)
        end = min(t + step, duration)
        if art == "harmonic":
            events.append({"type": "harmonic", "time": _r(t), "string": string,
                           "fret": int(rng.choice([5, 7, 12])), "release": _r(t + 0.05)})
            events.append({"type": "pluck", "time": _r(t + 0.002), "string": string,
                           "force": force, "style": style})
        else:
            events.append({"type": "fret", "time": _r(t), "string": string, "fret": fret,
                           "force": press})
            events.append({"type": "pluck", "time": _r(t + 0.005), "string": string,
                           "force": force, "style": style})
            mid = t + 0.5 * (end - t)
            if art == "hammer_on" and mid < duration:
                events.append({"type": "hammer_on", "time": _r(mid), "string": string,
                               "fret": fret + 2, "force": press})
            elif art == "pull_off" and mid < duration and fret >= 1:
                events.append({"type": "hammer_on", "time": _r(t + 0.01), "string": string,
                               "fret": fret + 2, "force": press})
                events.append({"type": "pull_off", "time": _r(mid), "string": string,
                               "fret": fret + 2, "force": _r(force / 2)})
            elif art == "slide" and fret >= 1 and mid < duration:
                to = int(np.clip(fret + rng.choice([-2, 2]), 1, top))
                events.append({"type": "slide", "time": _r(mid), "string": string,
                               "from_fret": fret, "to_fret": to,
                               "duration": _r(min(0.15, (end - mid) * 0.8) or 0.05),
                               "force": press})
                fret = to
            elif art == "bend" and fret >= 1:
                events.append({"type": "bend", "time": _r(t + 0.02), "string": string,
                               "semitones": float(rng.choice([0.5, 1.0, 2.0])),
                               "duration": _r(min(0.15, step / 3))})
            elif art == "vibrato":
                events.append({"type": "vibrato", "time": _r(t + 0.02), "string": string,
                               "depth_cents": _r(rng.uniform(10, 40)),
                               "rate_hz": _r(rng.uniform(4, 7)), "duration": _r(step)})
            elif art == "mute":
                events.append({"type": "mute", "time": _r(t), "string": string,
                               "amount": _r(rng.uniform(0.3, 0.9)), "release": _r(end)})
        t += step
    return [e for e in events if e["time"] < duration]
