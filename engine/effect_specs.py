"""The effects a track of a scene may run its output through: their schema, in units.

Each effect is one of Spotify's ``pedalboard`` plugins (``engine.effects`` builds them; this module
is schema only and loads no numerics).  Parameters are in units (dB, Hz, seconds, 0..1 fractions)
with documented ranges; a ``mix`` is the wet fraction (0 dry .. 1 wet).

Levels: a track's effects see its signal at the fixed output scale (``engine.output.FIXED_GAIN``:
the scale of ``normalize: false`` and of streams, where 1.0 is full scale, 0 dBFS), so a
compressor's ``threshold_db`` or a drive's ``gain_db`` mean the same thing whatever the scene's
normalisation.

Convolution takes only a built-in impulse response (``ir``: the modal guitar bodies of
``engine.output.BODIES``, run as their recursive filter, which is exact convolution with the whole
response); a file path would let a request read the server's files and an uploaded response would
let it fill the server's memory.  Python callers
can convolve any response they hold with ``engine.render(..., impulse_response=...)``.

Tails: a delay's repeats and a reverb's tail that would sound after the scene's ``duration`` are
cut there (the scene is that long); give the scene a longer duration to hear them.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, ConfigDict, Field

MAX_EFFECTS = 16  # per track


class _Effect(BaseModel):
    # the same strictness as engine.scene._Model (which this module may not import: it is below it)
    model_config = ConfigDict(extra="forbid", allow_inf_nan=False)


Mix = Annotated[float, Field(ge=0.0, le=1.0, description="wet fraction: 0 dry .. 1 wet")]


class Drive(_Effect):
    """Overdrive: ``gain_db`` of gain into a tanh soft clipper (pedalboard ``Distortion``)."""

    type: Literal["drive"] = "drive"
    gain_db: float = Field(20.0, ge=0.0, le=60.0, description="gain into the clipper, dB")


class Compressor(_Effect):
    """Dynamic range compressor (pedalboard ``Compressor``)."""

    type: Literal["compressor"] = "compressor"
    threshold_db: float = Field(-20.0, ge=-60.0, le=0.0, description="dBFS at the fixed gain")
    ratio: float = Field(4.0, ge=1.0, le=30.0, description="input dB over output dB above threshold")
    attack_s: float = Field(0.005, ge=1e-4, le=1.0, description="attack time, s")
    release_s: float = Field(0.1, ge=1e-3, le=5.0, description="release time, s")


class Highpass(_Effect):
    """First-order high-pass filter (pedalboard ``HighpassFilter``, -6 dB/octave)."""

    type: Literal["highpass"] = "highpass"
    cutoff_hz: float = Field(80.0, ge=10.0, le=20000.0, description="-3 dB frequency, Hz")


class Lowpass(_Effect):
    """First-order low-pass filter (pedalboard ``LowpassFilter``, -6 dB/octave); a guitar cabinet
    is roughly a low-pass near 5 kHz."""

    type: Literal["lowpass"] = "lowpass"
    cutoff_hz: float = Field(5000.0, ge=10.0, le=20000.0, description="-3 dB frequency, Hz")


class _Band(_Effect):
    """What the EQ bands share: their gain and their width."""

    gain_db: float = Field(0.0, ge=-24.0, le=24.0, description="boost (+) or cut (-), dB")
    q: float = Field(0.707, ge=0.1, le=20.0, description="quality factor")


class Peak(_Band):
    """Peaking EQ band (pedalboard ``PeakFilter``)."""

    type: Literal["peak"] = "peak"
    cutoff_hz: float = Field(1000.0, ge=10.0, le=20000.0, description="centre frequency, Hz")


class LowShelf(_Band):
    """Low-shelf EQ (pedalboard ``LowShelfFilter``)."""

    type: Literal["low_shelf"] = "low_shelf"
    cutoff_hz: float = Field(200.0, ge=10.0, le=20000.0, description="shelf frequency, Hz")


class HighShelf(_Band):
    """High-shelf EQ (pedalboard ``HighShelfFilter``)."""

    type: Literal["high_shelf"] = "high_shelf"
    cutoff_hz: float = Field(4000.0, ge=10.0, le=20000.0, description="shelf frequency, Hz")


class Chorus(_Effect):
    """Chorus (pedalboard ``Chorus``): a modulated short delay mixed with the dry signal."""

    type: Literal["chorus"] = "chorus"
    rate_hz: float = Field(1.0, ge=0.01, le=20.0, description="modulation rate, Hz")
    depth: float = Field(0.25, ge=0.0, le=1.0, description="modulation depth, 0..1")
    centre_delay_s: float = Field(0.007, ge=1e-3, le=0.05, description="centre delay, s")
    feedback: float = Field(0.0, ge=-0.95, le=0.95, description="feedback fraction")
    mix: Mix = 0.5


class Delay(_Effect):
    """Echo (pedalboard ``Delay``): repeats every ``delay_s``, each ``feedback`` times the last."""

    type: Literal["delay"] = "delay"
    delay_s: float = Field(0.35, ge=1e-3, le=5.0, description="time between repeats, s")
    feedback: float = Field(0.3, ge=0.0, le=0.95, description="level of each repeat over the last")
    mix: Mix = 0.3


class Reverb(_Effect):
    """Room reverb (pedalboard ``Reverb``, the Freeverb algorithm)."""

    type: Literal["reverb"] = "reverb"
    room_size: float = Field(0.5, ge=0.0, le=1.0, description="0 small .. 1 large room")
    damping: float = Field(0.5, ge=0.0, le=1.0, description="high-frequency damping, 0..1")
    width: float = Field(1.0, ge=0.0, le=1.0, description="stereo width, 0..1")
    mix: Mix = 0.3


class Convolution(_Effect):
    """Convolution with a built-in impulse response: ``ir`` names a modal guitar body of
    ``engine.output.BODIES`` (an acoustic's or a classical's), e.g. to give an electric's track an
    acoustic body; ``mix`` of it added to ``1 - mix`` of the dry signal."""

    type: Literal["convolution"] = "convolution"
    ir: Literal["acoustic", "classical"] = Field(description="built-in impulse response")
    mix: Mix = 1.0


Effect = Annotated[
    Drive | Compressor | Highpass | Lowpass | Peak | LowShelf | HighShelf | Chorus | Delay | Reverb
    | Convolution,
    Field(discriminator="type"),
]
