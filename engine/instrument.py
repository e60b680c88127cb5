"""One face for both physical models: an instrument prepared from one track's scene, rendered block
by block, and played live.  ``engine.models`` picks the model a scene names; the mixer, the
renderer and the live session hold instruments and never ask which model they hold.

What the two models share is written here once:

* ``Output``, ``output_of``: the pickups, pan, body and length that a scene's ``output`` asks for;
* ``Instrument``: the block loop (``blocks``, ``render_frames``: every voice's samples panned,
  summed and through the body, counted in output frames), a voice by its string, a session's
  start at rest, and the face each model fills in (``voice_frames``, ``energy_error``,
  ``warnings``, ``live_delay``, ``rebuild``, ``tension_breakpoints``);
* ``is_lift``, ``lift_kept``: the part of a live session's event pruning that is the player's;
* ``DECAY_CHECK_FRAMES``: where both models test a string for decay.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .output import Body, add_to_mix, default_pan, pan_gains
from .presets import Preset
from .scene import Fret, Scene, Slide, Tap, frame_count

# The decay skip tests a string every this many output frames (on the global step grid, whatever
# the block size): the samples a render gives do not depend on its blocks.
DECAY_CHECK_FRAMES = 1024

FINGERS = (Fret, Tap, Slide)  # the events that put a finger down (HammerOn is a Tap)


@dataclass(frozen=True)
class Output:
    """What a scene's ``output`` asks of an instrument: the pickups (x / L) and their gains, each
    string's (left, right) pan gains, the body (None: none) and the length in frames."""

    pickups: list[float]
    gains: np.ndarray
    channels: int
    pans: dict[int, tuple[float, float]]
    body: Body | None
    frames: int


def output_of(scene: Scene, preset: Preset) -> Output:
    out = scene.output
    if out.pickups:
        pickups = [p.position for p in out.pickups]
        gains = np.array([p.gain for p in out.pickups], float)
    else:
        pickups = [out.pickup_position or preset.pickup_position]
        gains = np.ones(1)
    pan = out.pan or default_pan(preset.n_strings)
    body_name = out.body or preset.body
    body = Body(body_name, float(scene.sample_rate), out.channels) if body_name != "none" else None
    return Output(pickups, gains, out.channels, {i + 1: pan_gains(p) for i, p in enumerate(pan)},
                  body, frame_count(scene))


@dataclass
class Instrument:
    """A scene's guitar prepared for rendering: a voice for each string that needs simulating
    (``voices``, each with its 1-based string ``index``, its ``oversample`` factor and a
    ``stopped`` flag), the pickups' pan and the body.  A model subclasses it and fills in the
    methods that raise ``NotImplementedError``."""

    scene: Scene
    preset: Preset
    voices: list
    options: Any  # the model's options (``block_frames`` is the default block)
    frames: int
    channels: int
    pans: dict[int, tuple[float, float]]
    body: Body | None
    frame: int = 0

    # ---- rendering ----------------------------------------------------------------------------

    def blocks(self, block_frames: int | None = None):
        """Yield the mix (pickup velocity, m/s, at the output rate; shape (m,) for mono and
        (m, 2) for stereo) block by block, through the body response if there is one."""
        bf = block_frames or self.options.block_frames
        while self.frame < self.frames:
            m = min(bf, self.frames - self.frame)
            yield self.render_frames(m)

    def render_frames(self, m: int, voice_frames: list[np.ndarray] | None = None,
                      strings: np.ndarray | None = None, body: bool = True) -> np.ndarray:
        """The next ``m`` frames: every voice's, panned and summed in the order of ``voices``,
        through the body (``body=False``: not through it; the mixer filters several tracks' sum
        through one body, ``engine.mix``).  ``voice_frames``: each voice's next ``m`` frames
        (``voice_frames``), already computed (on other threads: ``engine.mix``); the sum is the
        same.

        ``strings``, an (m, n_strings) array of zeros: each string's own samples are written into
        it as they are mixed, before pan and body (its stem), column ``k`` the string
        ``n_strings - k`` (the lowest first, as the labels order a track's strings); a string
        with no voice stays zero."""
        mix = np.zeros((m, self.channels)) if self.channels == 2 else np.zeros(m)
        end = self.frame + m
        for i, v in enumerate(self.voices):
            y = self.voice_frames(v, end) if voice_frames is None else voice_frames[i]
            if strings is not None:
                strings[:, self.preset.n_strings - v.index] = y
            add_to_mix(mix, y, self.pans[v.index])
        self.frame = end
        return self.body(mix) if body and self.body is not None else mix

    def voice_frames(self, voice, end: int) -> np.ndarray:
        """One voice's pickup velocity at the output rate, from ``self.frame`` up to frame
        ``end``.  It touches that voice's state only, so the voices of a block may be computed
        on several threads at once (the kernels release the GIL)."""
        raise NotImplementedError

    def energy_error(self) -> float:
        """The largest relative deviation of the discrete energy balance over the voices."""
        raise NotImplementedError

    def warnings(self) -> list[str]:
        """What may not sound as the player means it (``engine.scene_warnings``)."""
        raise NotImplementedError

    # ---- live play ----------------------------------------------------------------------------

    @property
    def live_delay(self) -> int:
        """Frames after a block boundary at which a live event acts: the steps a voice has
        already computed past the boundary (``engine.live``)."""
        raise NotImplementedError

    def rebuild(self, voice, events: list, prune: bool) -> list:
        """Compile ``voice`` again from ``events`` (its string's so far, sorted), keeping its
        state, so that it runs again; with ``prune``, first drop the events whose effect is over
        (the samples stay the same).  Returns the events kept."""
        raise NotImplementedError

    def tension_breakpoints(self, voice) -> tuple[np.ndarray, np.ndarray, int]:
        """The voice's tension (or pitch) breakpoints: their steps, their ratios to the tuned
        value, and the steps per output frame."""
        raise NotImplementedError

    def voice(self, string: int):
        return next(v for v in self.voices if v.index == string)

    def at_rest(self) -> None:
        """Every voice at rest: nothing to compute until an event comes (a live session's
        start)."""
        for v in self.voices:
            v.stopped = True

    def tension_settled(self, voice, frame: int) -> bool:
        """Whether the voice's tension is at its tuned value for good from output ``frame`` on
        (a bend released and returned, a vibrato over)."""
        steps, ratios, per_frame = self.tension_breakpoints(voice)
        return steps.size == 0 or (steps[-1] <= frame * per_frame and ratios[-1] == 1.0)


def is_lift(e: Any) -> bool:
    """A ``fret`` 0: it lifts the fingers down on its string and puts none."""
    return isinstance(e, Fret) and e.fret == 0


def lift_kept(e: Any, events: list, keep: list[bool], step: int, rate: float) -> bool:
    """Whether pruning keeps the lift ``e``: while it is still to come, or some finger kept
    (``keep``, decided first) was put down before it, which it may have lifted (without it, that
    finger would be held again when the string is compiled)."""
    return round(e.time * rate) >= step or any(
        k and isinstance(x, FINGERS) and not is_lift(x) and x.time <= e.time
        for x, k in zip(events, keep, strict=True))
