"""The digital-waveguide guitar of Evangelista & Eckerholm 2010 (IEEE TASLP 18(4)), beside the
finite-difference model: the same scenes, presets and output conventions.

    >>> from engine import models, waveguide
    >>> inst = waveguide.prepare(engine.parse_scene({... "model": "waveguide"}),
    ...                          statics=models.PRESSED_STRING)
    >>> audio = np.concatenate(list(inst.blocks(4096)))   # pickup velocity, m/s, mono

Modules, one per object, each opening with the equations it implements:

* ``string``     displacement-wave rails, the termination's fractional delay (third-order
                 Lagrange), loss (one-pole fitted to the presets' two T60 values) and dispersion
                 (allpass cascade) filters, the tuning;
* ``pluck``      the plucking junction: a time-varying mass-spring-damper with the scene's force
                 pulse, tapered over the contact (also the light finger, harmonic touch, palm);
* ``fingering``  the fingering termination (a stopped string), its pitch and rest line;
* ``collision``  the collision junctions along the neck (frets, fretboard), active only where the
                 string can reach them;
* ``glide``      tension modulation (pitch glide of hard plucks);
* ``controls``   scene events -> a string's timeline;
* ``kernel``     the numba sample loop;
* ``voice``      one string's state across blocks and the changes of its stop.

Output: the string velocity at the pickup positions (m/s) summed over strings (panned and through
the body response as the finite-difference guitar does), at the scene's sample rate (no
oversampling: a waveguide at X = c T is exact for the ideal string), so ``engine.FIXED_GAIN``
and the body response apply unchanged.  One difference of timing: the
finite-difference output sample m is the velocity at (m + 1/2) / rate, this one's at
(m - 1/2) / rate (a backward difference), one sample apart.

Where each model is better (``benchmarks/waveguide.py`` measures it and says so in its docstring):
the waveguide is over an order of magnitude cheaper (in instructions, over twenty times on a
fretted six-string strum; in time, by a ratio that moves with the machine) and tunes every note
exactly through its fractional delay (open strings, stopped strings, bends); the
finite-difference model computes what the waveguide approximates:
the frets' intonation physics (pressing stretch, stiffness over the crown), the finger's own
dynamics on the string (the waveguide takes only its damping of a held note, fitted to the
finite-difference analysis: ``fingering``), a distributed Kirchhoff-Carrier tension, penalty
contacts with an exact energy balance, and the transients of pressing a finger down; its
spectrum is the reference's.

What the waveguide takes from the finite-difference string (which notes a finger seats, and a
held note's decay by the finger) it is handed as an ``engine.statics.PressedString`` (``statics``,
given by ``engine.models``): this package imports nothing of ``engine.fd``.  A scene's first
fretted notes cost more than the rest: each fret a finger holds asks that held-note analysis for
the finger's damping (an eigenvalue problem a fret),
once per machine: the result is kept on disk (``engine.calibration_store``;
``WaveguideOptions(finger_damping=False)`` leaves the damping out).

Live sessions (``engine.live``, ``model="waveguide"``) play this model too: a string's events are
compiled again as they come (``rebuild``, ``WaveguideVoice.rebuild``) and act ``LIVE_DELAY``
samples after the block boundary that follows them (the kernel looks that far ahead at the
events: ``kernel``).  Their held notes are damped by the finger as a render's are: the session's
guitar is prepared with every fret's damping (``options_from``: ``RenderOptions(live_grid=True)``,
``WaveguideOptions.every_fret``), so that no note held later waits for an analysis.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..instrument import FINGERS, Instrument, is_lift, lift_kept, output_of
from ..performance import events_by_string
from ..presets import Preset
from ..scene import Bend, Harmonic, Mute, Scene, Vibrato
from ..statics import PressedString
from .controls import timeline
from .fingering import INTONATION, finger_decays
from .kernel import LOOKAHEAD
from .string import physical
from .voice import WaveguideVoice

__all__ = ["LIVE_DELAY", "WaveguideOptions", "WaveguideInstrument", "options_from", "prepare",
           "rebuild", "render", "timeline_of"]

LIVE_DELAY = LOOKAHEAD  # samples after a block boundary at which a live event acts


@dataclass
class WaveguideOptions:
    """Switches of the waveguide model (the benchmarks and tests turn them)."""

    intonation: str = "ideal"  # ``fingering``: "ideal" (12-TET at the frets) or "physical"
    dispersion: bool = True
    collisions: bool = True
    glide: bool = True
    finger_damping: bool = True  # ``fingering.finger_reflection``
    # every fret's finger damping computed when the guitar is prepared, not when a note is first
    # held there (a live session's guitar: ``RenderOptions.live_grid``); the samples are the same
    every_fret: bool = False
    skip_silent: bool = True
    skip_decayed: bool = True
    decay_velocity: float = 1e-7  # m/s, as the finite-difference model's
    # steady junctions (dampers in contact, released junctions leaking away) stepped in the
    # kernel's plain runs (``kernel._steady``): the same samples, to the bit
    steady_runs: bool = True
    # the collision points beside a damper in contact (a damp, a palm, a harmonic touch, a light
    # finger) bounded by the string's energy as everywhere else, not all tested every sample
    # (``kernel._reach``)
    damper_bound: bool = True
    # the damped rest (``kernel._settle``): a string under a plain damper (a damp, a palm, a
    # touch, a light finger) whose pickups have fallen below decay_velocity and whose points move
    # slower than this (m/s) is held at rest by the hand, where the junctions' leak would let it
    # creep back to its rest line for seconds.  Part of the model (it acts with skip_decayed
    # off too); 0: no rest, the creep runs to the string's next note (docs/engine.md, "Skips")
    damped_velocity: float = 1e-4
    block_frames: int = 2048


@dataclass
class WaveguideInstrument(Instrument):
    """A scene's guitar prepared for the waveguide (``engine.instrument.Instrument``): a
    ``WaveguideVoice`` per string that needs simulating, at the scene's rate."""

    _warnings: list[str] = field(default_factory=list)

    def voice_frames(self, voice: WaveguideVoice, end: int) -> np.ndarray:
        return voice.run(end - self.frame)  # nothing computed while at rest or decayed

    def energy_error(self) -> float:
        """0.0: the waveguide has no discrete energy balance to report.  Its terminations hold
        state in recursive filters, so the stored energy is not one expression of the rails at an
        instant; passivity is argued junction by junction in the modules' docstrings and checked
        by ``tests/engine/waveguide/test_passivity.py`` (the rails' energy, ``WaveguideVoice
        .energy``, never grows once the forces stop)."""
        return 0.0

    def warnings(self) -> list[str]:
        return list(self._warnings)

    # ---- live play (``engine.live``) ----------------------------------------------------------

    @property
    def live_delay(self) -> int:
        return LIVE_DELAY

    def tension_breakpoints(self, voice: WaveguideVoice) -> tuple[np.ndarray, np.ndarray, int]:
        return voice.pb_step, voice.pb_f, 1  # the pitch ratio's, at the scene's rate

    def rebuild(self, voice: WaveguideVoice, events: list, prune: bool) -> list:
        """Compile the string's timeline again (``WaveguideVoice.rebuild``); it runs again (a
        string at rest or decayed too)."""
        if prune:
            events = _prune(voice, events)
        rebuild(voice, events)
        return events


def _seating(statics: PressedString, preset: Preset, string: int, rate: float):
    """seated(fret, force): does a finger pressing ``force`` N rest the string on ``fret``?  The
    pressed string's statics (``statics.seating_force_n``: both models agree on which notes are
    dead)."""

    def seated(fret: int, force: float | None) -> bool:
        if force is None or fret < 1:
            return True  # a finger with no force of its own presses hard enough
        return force >= statics.seating_force_n(preset, string, rate, fret)

    return seated


def prepare(scene: Scene, options: WaveguideOptions | None = None, *,
            statics: PressedString) -> WaveguideInstrument:
    """Design every string that the scene plays and compile its events.  ``statics``: the
    pressed string's seating forces and held-note decays (``engine.models.PRESSED_STRING``)."""
    opts = options or WaveguideOptions()
    if opts.intonation not in INTONATION:
        raise ValueError(f"intonation must be one of {INTONATION}")
    preset = scene.preset()
    rate = float(scene.sample_rate)
    out = output_of(scene, preset)
    pickups, gains = out.pickups, out.gains
    voices = []
    warnings: list[tuple[float, str]] = []
    by_string = events_by_string(scene, preset.n_strings)
    for i in range(1, preset.n_strings + 1):
        phys = physical(preset, i)
        seated = _seating(statics, preset, i, rate)
        tl = timeline(scene, preset, i, rate, phys.impedance, seated, by_string[i])
        if opts.skip_silent and not tl.slots and not tl.fingers:
            continue
        for f in tl.fingers:
            if not f.seated:
                warnings.append((f.on / rate, f"string {i}: the finger at {f.on / rate:g} s "
                                 f"presses {f.force:g} N, too lightly to rest the string on "
                                 f"fret {f.fret}: the note sounds dead"))
        if opts.finger_damping and opts.every_fret:
            finger_decays(statics, preset, i, rate, range(1, preset.frets + 1))
        voices.append(WaveguideVoice(i, preset, phys, tl, rate, pickups, gains, opts.intonation,
                                     statics, opts.dispersion, opts.collisions, opts.glide,
                                     opts.finger_damping, opts.skip_decayed,
                                     opts.decay_velocity, opts.steady_runs,
                                     opts.damper_bound, opts.damped_velocity))
    inst = WaveguideInstrument(scene, preset, voices, opts, out.frames, out.channels, out.pans,
                               out.body)
    inst._warnings = [w for _, w in sorted(warnings)]
    return inst


def options_from(render_options) -> WaveguideOptions:
    """The waveguide's options for an ``engine.RenderOptions`` (what the two models share).
    ``live_grid`` (a live session's configuration) computes the finger's damping of every fret
    when the guitar is prepared (``WaveguideOptions.every_fret``)."""
    if render_options is None:
        return WaveguideOptions()
    return WaveguideOptions(skip_silent=render_options.skip_silent,
                            skip_decayed=render_options.skip_decayed,
                            decay_velocity=render_options.decay_velocity,
                            block_frames=render_options.block_frames,
                            every_fret=render_options.live_grid)


def timeline_of(voice: WaveguideVoice, events: list):
    """The timeline (``controls.Timeline``) of a live session's string from its events so far
    (that string's, strums split, with their times)."""
    return timeline(None, voice.preset, voice.index, voice.rate, voice.phys.impedance,
                    _seating(voice.statics, voice.preset, voice.index, voice.rate), events)


def rebuild(voice: WaveguideVoice, events: list) -> None:
    """Compile a live session's string again from its events so far, keeping its state
    (``WaveguideVoice.rebuild``)."""
    voice.rebuild(timeline_of(voice, events))


def render(scene: Scene, options: WaveguideOptions | None = None, *,
           statics: PressedString) -> np.ndarray:
    """The whole scene's pickup velocity (m/s; through the body and panned as the scene's output
    says): the blocks concatenated."""
    inst = prepare(scene, options, statics=statics)
    parts = list(inst.blocks())
    return np.concatenate(parts) if parts else np.zeros(0)


# a junction's pulse (at most 50 ms), release (at most the pulse) and leak (8 time constants at
# ``pluck.LEAK_HZ``, 64 ms) are over this long after it starts or lets go
_OVER_S = 0.2


def _prune(v: WaveguideVoice, events: list) -> list:
    """Drop the events whose effect is over at the voice's current step (the same samples: the
    kernel skips all of these): plucks (and pull-offs) whose junction has let go and leaked away,
    fingers lifted as long ago (and fret-0 lifts past with no finger kept that they may have
    lifted), dampers released as long ago, bends and vibratos when the pitch is back at its tuned
    value for good.  ``_OVER_S`` bounds each junction's pulse, release and leak."""
    step = v.step
    rate = v.rate
    over = round(_OVER_S * rate)
    tension_done = v.pb_step.size == 0 or (v.pb_step[-1] < step and v.pb_f[-1] == 1.0)
    # one finger per finger event, in their order (a fret 0 lifts, it puts no finger)
    fingers = iter(timeline_of(v, events).fingers)
    keep = [False] * len(events)
    for i, e in enumerate(events):  # fingers first: a lift is kept with them
        if isinstance(e, FINGERS) and not is_lift(e):
            f = next(fingers)
            keep[i] = round(e.time * rate) >= step or f.rel + over >= step
    for i, e in enumerate(events):
        on = round(e.time * rate)
        if is_lift(e):
            keep[i] = lift_kept(e, events, keep, step, rate)
        elif isinstance(e, FINGERS):
            continue
        elif on >= step:
            keep[i] = True
        elif isinstance(e, Bend | Vibrato):
            keep[i] = not tension_done
        elif isinstance(e, Mute | Harmonic):
            keep[i] = e.release is None or round(e.release * rate) + over >= step
        else:  # a pluck or a pull-off
            keep[i] = on + 2 * over >= step
    return [e for e, k in zip(events, keep, strict=True) if k]
