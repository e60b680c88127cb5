"""Live play messages (``../shared/API.md``, "Live play"): what opens a session and the events a
player sends while it runs.  Schema only (pydantic, no numerics), so a front end validates them
without loading the engine.

An event is the scene's event object (``engine.scene``) without ``time``: it acts at the next block
boundary, or ``offset`` frames into that block.  Its ``release`` (where it has one) is relative:
seconds after the event acts.  One event exists only here: ``release``, which lifts now what is
held on a string (its fingers, its bend, a palm mute, a harmonic touch), as if the event that put
it there had been given that release time.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any, Literal

from pydantic import Field, ValidationError

from .presets import Preset
from .scene import (
    SAMPLE_RATE_MAX,
    SAMPLE_RATE_MIN,
    Bend,
    Fret,
    Guitar,
    HammerOn,
    Harmonic,
    ModelName,
    Mute,
    Pluck,
    PullOff,
    QualityName,
    Scene,
    Slide,
    Strum,
    Tap,
    Vibrato,
    _Model,
)

BLOCK_FRAMES_MIN = 32
BLOCK_FRAMES_MAX = 4096
# what a ``release`` lifts
RELEASABLE = ("all", "finger", "bend", "mute", "harmonic")


class Release(_Model):
    """Lift now what is held on ``string`` (every string if omitted): ``what`` picks fingers, the
    bend (it returns over its own duration), the palm mute, the harmonic touch, or all of them."""

    type: Literal["release"] = "release"
    string: int | None = Field(None, ge=1, le=12, description="omit for every string")
    what: Literal["all", "finger", "bend", "mute", "harmonic"] = "all"


EVENT_TYPES: dict[str, type[_Model]] = {
    m.model_fields["type"].default: m
    for m in (Pluck, Fret, Tap, HammerOn, PullOff, Slide, Bend, Vibrato, Harmonic, Mute, Strum,
              Release)
}


class LiveOpen(_Model):
    """The first message of a session."""

    type: Literal["open"] = "open"
    preset: str | None = Field(None, description="a preset name (shorthand for guitar.preset)")
    guitar: Guitar = Field(default_factory=Guitar, description="preset and overrides, as a scene's")
    sample_rate: int = Field(44100, ge=SAMPLE_RATE_MIN, le=SAMPLE_RATE_MAX, description="Hz")
    block_frames: int = Field(256, ge=BLOCK_FRAMES_MIN, le=BLOCK_FRAMES_MAX,
                              description="frames per block sent")
    quality: QualityName = "draft"
    model: ModelName = Field(
        "fdtd", description="the string model: finite differences (default) or digital "
                            "waveguides (``quality`` does nothing there)")

    def scene_guitar(self) -> Guitar:
        if self.preset is None:
            return self.guitar
        return Guitar.model_validate({**self.guitar.model_dump(exclude_unset=True),
                                      "preset": self.preset})


class LiveError(ValueError):
    """A message that cannot be played: ``field`` names what is wrong (``events`` style paths:
    ``force``, ``offset``, ``strings[2]``), ``message`` says why and what is allowed."""

    def __init__(self, field: str, message: str):
        super().__init__(f"{field}: {message}")
        self.field = field
        self.message = message


@dataclass(frozen=True)
class LiveEvent:
    event: Any  # the scene's event model with time 0 and a relative release, or a ``Release``
    offset: int  # frames into the next block


def _field(loc: tuple) -> str:
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else (f".{part}" if out else str(part))
    return out or "message"


# A cross-field check of the scene names its field at the start of its message:
# "guitar.strings: string 6 outside 1..4".
_FIELD_IN_MESSAGE = re.compile(r"^((?:[a-z_]+(?:\[\d+\])?\.)*[a-z_]+(?:\[\d+\])?): (.+)$", re.S)


def validation_error(exc: ValidationError) -> LiveError:
    """The first error of a pydantic validation as a ``LiveError`` naming its field."""
    err = exc.errors()[0]
    msg = err["msg"].removeprefix("Value error, ")
    if not err["loc"] and (m := _FIELD_IN_MESSAGE.match(msg)):
        return LiveError(m.group(1), m.group(2))
    return LiveError(_field(tuple(err["loc"])), msg)


def parse_live_open(msg: Any) -> LiveOpen:
    if not isinstance(msg, dict):
        raise LiveError("message", "the first message opens the session: a JSON object "
                                   '{"type": "open", "preset": ..., "sample_rate": ..., '
                                   '"block_frames": ...}')
    if msg.get("type", "open") != "open":
        raise LiveError("type", f"the first message must open the session (type 'open'), "
                                f"not {msg.get('type')!r}")
    try:
        opened = LiveOpen.model_validate(msg)
        Scene(duration=1.0, guitar=opened.scene_guitar())  # a guitar's cross-field checks
    except ValidationError as exc:
        raise validation_error(exc) from None
    return opened


def parse_live_event(msg: Any, preset: Preset, block_frames: int) -> LiveEvent:
    """Validate one event message for a session on ``preset`` with blocks of ``block_frames``."""
    if not isinstance(msg, dict):
        raise LiveError("message", "an event is a JSON object with a 'type'")
    kind = msg.get("type")
    if kind not in EVENT_TYPES:
        raise LiveError("type", f"unknown event type {kind!r}; one of {sorted(EVENT_TYPES)}")
    if "time" in msg:
        raise LiveError("time", "not taken in live play: an event acts at the next block, or "
                                "'offset' frames into it")
    body = dict(msg)
    offset = body.pop("offset", 0)
    if isinstance(offset, bool) or not isinstance(offset, int) or not 0 <= offset < block_frames:
        raise LiveError("offset", f"{offset!r} is not a whole number of frames in "
                                  f"0..{block_frames - 1} (this session's block)")
    model = EVENT_TYPES[kind]
    if model is not Release:
        body["time"] = 0.0  # the release, relative, must then be > 0 as the scene asks
    try:
        event = model.model_validate(body)
    except ValidationError as exc:
        raise validation_error(exc) from None
    n = preset.n_strings
    string = getattr(event, "string", None)
    if string is not None and string > n:
        raise LiveError("string", f"{string} outside 1..{n} for {preset.name}")
    for j, st in enumerate(getattr(event, "strings", None) or []):
        if st > n:
            raise LiveError(f"strings[{j}]", f"{st} outside 1..{n} for {preset.name}")
    for name in ("fret", "from_fret", "to_fret"):
        fret = getattr(event, name, None)
        if fret is not None and fret > preset.frets:
            raise LiveError(name, f"{fret} outside 0..{preset.frets} for {preset.name}")
    return LiveEvent(event, offset)
