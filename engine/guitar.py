"""Many strings: per-string state, block rendering, skips, oversampling and mixing.

Each string is simulated on its own (the DAFx24 model has no coupling between strings) at an internal
rate ``oversample * sample_rate`` and decimated to the output rate by a linear-phase FIR filter whose
state is carried across blocks.  The output is the string *velocity* at the pickup point (m/s): it is
what a magnetic pickup senses and, like the bridge force that drives an acoustic top, it carries no
static offset when a finger presses the string down (a displacement output would jump by the
fretting depth).

Skips (each bounded by a test in ``tests/engine/test_skips.py`` and measured in ``benchmarks/``):
* a string with no events is never simulated (its output is exactly zero);
* contact work is done only where contact is possible: the linear pass counts the nodes below the
  fretboard and within reach of a fret tip (its height plus a bound on how far a node moves in
  one step, ``string.fret_margin``); a quiet step looks at the frets only when one is within
  reach.  The fretboard column is formed only when a node is below the board (or a residual psi
  remains), a finger only while it exists, rigid frets only while active or within reach;
* quiet steps (nothing but the string's own forces act, no contact happens) run in a loop of
  their own that computes the same samples (``kernels._quiet_run``);
* held steps (one finger presses the string onto its frets, nothing changes which forces act) run
  in a loop of their own that does the general path's arithmetic without its bookkeeping
  (``kernels._held_run``; bit-identical, ``tests/engine/test_held.py``);
* in quiet steps the Kirchhoff-Carrier column is left out while its tension rise is below the
  quality's ``kc_tolerance`` x T0 (``standard``: 1e-4, under 0.09 cents of pitch; ``high``: never);
* a string whose motion has decayed below ``decay_velocity`` (m/s at every node and at the pickup)
  after its last event stops being computed; its remaining output is below that level.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from functools import partial

import numpy as np
from scipy import signal

from . import kernels
from .controls import (
    NEVER,
    StringControls,
    events_on,
    frets_pressed,
    max_tension_ratio,
    stopped_frets,
    string_controls,
)
from .intonation import SEAT_MARGIN, fret_shifts, press_force, seating_force
from .output import Body, default_pan, pan_gains
from .presets import Preset
from .scene import Scene, Slide
from .string import (
    FRET_PENALTY,
    FRET_RIGID,
    StringModel,
    coefficients,
    dispersion_cents,
    fret_margin,
    geometry,
    kc_skip_level,
    tension_ratio_for_cents,
    tune,
)

FINGER_EVENTS = ("fret", "tap", "hammer_on", "slide")

# Output gain for ``normalize: false`` and for streams: pickup velocity (m/s) -> full scale.  A 2 N
# strum of the six open strings peaks near 0.26 and an 8 N one near 0.8 (benchmarks/skips.py prints
# the peaks); louder scenes clip in PCM, which is what a fixed gain means.
FIXED_GAIN = 0.03


@dataclass(frozen=True)
class Quality:
    """Accuracy/cost knobs; the scene's ``quality`` picks one of ``QUALITY``."""

    max_h_m: float  # strings are oversampled until their grid spacing is at most this
    max_dispersion_cents: float = math.inf  # ... and partials 1-10 are this close to f_n
    max_oversample: int = 8
    fret_mode: int = FRET_RIGID
    grid_scale: float = 1.0
    # quiet steps leave Kirchhoff-Carrier out while its tension rise is below this share of T0:
    # the pitch it would add is then below about 866 x this many cents (``string.kc_skip_level``)
    kc_tolerance: float = 0.0
    # the interpolants of the frets a scene's fingers stop are calibrated on the string's grid
    # (``engine.intonation``): the held note gets the fine grid's pitch.  On at draft and standard,
    # where it takes the grid's 13.8 and 4.9 cents out of the fretted pitch (against x8 everywhere,
    # benchmarks/pareto.py); off at high, whose fine grid leaves 1.7 cents and where it cost more
    # spectral accuracy (tap, fret buzz) than it bought (docs/accuracy.md)
    calibrate_frets: bool = False


QUALITY = {
    "draft": Quality(max_h_m=1.0, kc_tolerance=1e-3, calibrate_frets=True),
    "standard": Quality(max_h_m=5.5e-3, max_dispersion_cents=0.8, kc_tolerance=1e-4,
                        calibrate_frets=True),
    "high": Quality(max_h_m=2.5e-3, max_dispersion_cents=0.3, max_oversample=16),
}


@dataclass
class RenderOptions:
    """Engine-level switches (the benchmarks and tests turn them; users pick ``quality``)."""

    quality: Quality | None = None
    oversample: int | None = None  # force one internal factor for every string
    kirchhoff_carrier: bool = True
    fretboard: bool = True
    frets: bool = True
    skip_silent: bool = True
    skip_decayed: bool = True
    # quiet steps and the unreachable-fret skip (False: every fret is within reach in every step,
    # and every step takes the general path)
    skip_contacts: bool = True
    # held steps of a fretted note in a loop of their own (``kernels._held_run``), the same
    # arithmetic as the general path: False sends them through the general path
    held_steps: bool = True
    decay_velocity: float = 1e-7  # m/s; -140 dB below the fixed-gain full scale
    # overrides ``Quality.kc_tolerance`` (0: Kirchhoff-Carrier in every step)
    kc_tolerance: float | None = None
    block_frames: int = 2048
    # knobs of the accuracy study (benchmarks/pareto.py): the gradient correction of sec. 4.7
    # (``GAMMA_RULES``) and the tuning of tension and stiffness against the grid's dispersion
    gamma_rule: str = "joint"
    compensate_dispersion: bool = True
    calibrate_frets: bool | None = None  # overrides ``Quality.calibrate_frets``


GAMMA_RULES = {"joint": kernels.GAMMA_JOINT, "own": kernels.GAMMA_OWN,
               "paper": kernels.GAMMA_PAPER, "none": kernels.GAMMA_NONE}


def oversample_for(spec, length: float, rate: float, q: Quality, max_ratio: float = 1.0,
                   compensate: bool = True) -> tuple[int, StringModel]:
    """Smallest factor (at most q.max_oversample) whose stable grid has h <= q.max_h_m (contacts
    resolved finely enough for fretted pitch) and whose partials 1-10 lie within
    q.max_dispersion_cents of the stiff-string frequencies (the scheme's dispersion error), with
    the string tuned at that factor."""
    for os_ in range(1, q.max_oversample + 1):
        m = tune(spec, length, rate * os_, q.grid_scale, compensate, max_ratio)
        if m.h <= q.max_h_m and dispersion_cents(m) <= q.max_dispersion_cents:
            return os_, m
    return q.max_oversample, m


class Decimator:
    """Linear-phase FIR low-pass (scipy's firwin, Kaiser window) + downsampling by an integer
    factor, with the input history kept across blocks.  Each output sample is one dot product in a
    fixed order (``kernels.fir_decimate``), so any block size gives bit-identical samples.

    The filter's delay is removed exactly, so strings at different factors line up in time: the
    kernel's output at step n is the velocity (u^(n+1) - u^n) / k, i.e. at time (n + 1/2) k, so
    output sample m of a string at the output rate is the velocity at (m + 1/2) / rate, and at
    factor f the same time is internal step m f + (f - 1) / 2.  A linear-phase FIR of ``ntaps``
    taps delays by (ntaps - 1) / 2 internal steps: 24 f + 1 taps for odd f, 24 f + 2 for even f
    (half a step more), so that the string run ``lead`` = (ntaps - 1) / 2 + (f - 1) / 2 steps
    ahead (an integer) gives output m centred on exactly that time.  The first output is taken
    at input index ``lead``; the string simply runs ``lead`` steps past the last frame.
    """

    def __init__(self, factor: int, rate_out: float):
        self.factor = factor
        self.pos = 0  # inputs consumed so far
        self.lead = 0
        if factor > 1:
            ntaps = 24 * factor + (1 if factor % 2 else 2)
            self.lead = (ntaps - 1 + factor - 1) // 2
            self.taps = signal.firwin(ntaps, 0.45 * rate_out, fs=rate_out * factor,
                                      window=("kaiser", 9.0))[::-1].copy()
            self.history = np.zeros(ntaps - 1)

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """The output samples whose input (index lead + m factor) is in this block."""
        if self.factor == 1:
            return x
        buf = np.concatenate((self.history, x))
        ahead = self.lead - self.pos
        start = ahead if ahead >= 0 else ahead % self.factor
        y = kernels.fir_decimate(buf, self.taps, start, self.factor, len(x))
        self.pos += len(x)
        self.history = buf[len(x):]
        return y


@dataclass
class Voice:
    """One string in a scene: model, coefficients, controls and the state carried across blocks."""

    index: int  # 1-based string number
    model: StringModel
    coefs: kernels.Coefs
    geom: kernels.Geo
    ctl: StringControls
    pickup_gains: np.ndarray
    oversample: int
    decimator: Decimator
    diagnostics: bool
    skip_decayed: bool
    decay_velocity: float
    tension_ratio: float = 1.0  # the highest the scene's bends reach, over the tuned tension
    step: int = 0
    stopped: bool = False
    energy_h: list = field(default_factory=list)
    energy_q: list = field(default_factory=list)
    energy_p: list = field(default_factory=list)
    _step_block: object = field(default=None, repr=False)  # kernels.entry_point of step_block

    def __post_init__(self):
        n = self.coefs.n
        nslot = len(self.ctl.arrays.fs_on)
        # q: the N - 1 interior nodes' q, and a 0 for the fixed end N + 1 (kernels._q_index)
        self.state = kernels.State(
            u=np.zeros(n + 3), u1=np.zeros(n + 3), uf=np.zeros(n + 3), q=np.zeros(n),
            psi=np.zeros(2), gprev_b=np.zeros(n + 3), gprev_f=np.zeros(n + 3),
            has_gprev=np.zeros(2, np.int64),
            fret_active=np.zeros(len(self.geom.fret_p), np.int64),
            f_state=np.zeros(nslot, np.int64), f_w=np.zeros(nslot), f_w1=np.zeros(nslot),
            f_psi=np.zeros(nslot), f_bprev=np.zeros(nslot), tens=np.zeros(2),
            s_last=np.array([np.inf, 1.0, 0.0]),
            run_steps=np.zeros(2, np.int64),
        )
        self.h_start = 0.0  # H^(-1/2): the string starts at rest

    @property
    def u(self) -> np.ndarray:
        return self.state.u

    @property
    def u1(self) -> np.ndarray:
        return self.state.u1

    def run(self, nsteps: int) -> np.ndarray:
        """Advance nsteps internal steps; return the pickup mix at the internal rate."""
        if self.stopped or nsteps == 0:
            self.step += nsteps
            return np.zeros(nsteps)
        out = np.zeros((len(self.pickup_gains), nsteps))
        d = self.diagnostics
        e_h = np.empty(nsteps if d else 0)
        e_q = np.empty(nsteps if d else 0)
        e_p = np.empty(nsteps if d else 0)
        args = (self.coefs, self.geom, self.ctl.arrays, self.state, self.step, nsteps, out, d,
                e_h, e_q, e_p)
        if self._step_block is None:  # the argument types are the same in every block
            self._step_block = kernels.entry_point(kernels.step_block, args)
        status = self._step_block(*args)
        if status != kernels.OK:
            raise FloatingPointError(f"string {self.index}: the simulation became non-finite")
        self.step += nsteps
        if d:
            self.energy_h.append(e_h)
            self.energy_q.append(e_q)
            self.energy_p.append(e_p)
        mix = self.pickup_gains @ out
        if self.skip_decayed and not d and self.step > self.ctl.last_step:
            self._maybe_stop(out)
        return mix

    def _maybe_stop(self, out: np.ndarray) -> None:
        # Nothing will act on the string again (no event pending; a finger still on the string
        # holds still), so stop once every node, every finger and the pickups move slower than
        # decay_velocity.  A finger with a release still to come keeps the string running.
        st = self.state
        active = st.f_state == kernels.ACTIVE
        if np.any(self.ctl.arrays.fs_rel[active] < NEVER):
            return
        k = self.coefs.k
        vmax = np.max(np.abs(st.u - st.u1)) / k
        if np.any(active):
            vmax = max(vmax, float(np.max(np.abs(st.f_w[active] - st.f_w1[active]))) / k)
        if vmax < self.decay_velocity and np.max(np.abs(out)) < self.decay_velocity:
            self.stopped = True

    def energy_error(self) -> float:
        """Largest relative energy-balance deviation (paper sec. 6.1):

        max_n |H^(n+1/2) - H^(n-1/2) + k Q^n - k P^n| / [max H]_2,
        with [.]_2 the nearest power of two below (the paper normalises by H^(1/2), which is zero
        for a string that starts at rest and is plucked; the largest stored energy is the scale).
        """
        if not self.energy_h:
            return 0.0
        h = np.concatenate(self.energy_h)
        q = np.concatenate(self.energy_q)
        p = np.concatenate(self.energy_p)
        hprev = np.concatenate(([self.h_start], h[:-1]))
        scale = np.max(np.abs(h))
        if scale == 0.0:
            return 0.0
        scale = 2.0 ** math.floor(math.log2(scale))
        return float(np.max(np.abs(h - hprev + q - p)) / scale)


@dataclass
class Engine:
    """A scene prepared for rendering: voices for the strings that need simulating."""

    scene: Scene
    preset: Preset
    voices: list[Voice]
    options: RenderOptions
    frames: int
    channels: int
    pans: dict[int, tuple[float, float]]
    body: Body | None
    frame: int = 0

    def blocks(self, block_frames: int | None = None):
        """Yield the mix (pickup velocity, m/s, at the output rate; shape (m,) for mono and
        (m, 2) for stereo) block by block, through the body response if there is one."""
        bf = block_frames or self.options.block_frames
        while self.frame < self.frames:
            m = min(bf, self.frames - self.frame)
            yield self.render_frames(m)

    def render_frames(self, m: int) -> np.ndarray:
        mix = np.zeros((m, self.channels)) if self.channels == 2 else np.zeros(m)
        for v in self.voices:
            target = (self.frame + m) * v.oversample + v.decimator.lead
            y = v.decimator(v.run(target - v.step))
            if self.channels == 2:
                gl, gr = self.pans[v.index]
                mix[:, 0] += gl * y
                mix[:, 1] += gr * y
            else:
                mix += y
        self.frame += m
        return self.body(mix) if self.body is not None else mix

    def energy_error(self) -> float:
        return max((v.energy_error() for v in self.voices), default=0.0)

    def warnings(self) -> list[str]:
        """``scene_warnings`` of the scene, on the grids its voices were built on (every string
        with a finger on it has a voice)."""
        n = self.preset.n_strings
        out = [w for v in self.voices for w in _finger_warnings(
            self.preset, v.index, events_on(self.scene, n, v.index), v.model, v.tension_ratio)]
        return [text for _, _, text in sorted(out)]


def frame_count(scene: Scene) -> int:
    """Output frames a scene renders: its duration at its rate, rounded."""
    return int(round(scene.duration * scene.sample_rate))


def string_model(preset: Preset, string: int, events: list, rate: float, q: Quality,
                 opts: RenderOptions) -> tuple[int, StringModel, float]:
    """The internal oversampling factor, the tuned string on its grid for ``events`` (those on
    ``string``), built for the highest tension the scene's bends reach, and that tension over the
    tuned one."""
    spec = preset.strings[string - 1]
    length = preset.string_length_m(string)
    comp = opts.compensate_dispersion
    probe = tune(spec, length, rate, q.grid_scale, comp)
    rmax = max_tension_ratio(events, partial(tension_ratio_for_cents, probe))
    if opts.oversample:
        return (opts.oversample,
                tune(spec, length, rate * opts.oversample, q.grid_scale, comp, rmax), rmax)
    # The contact resolution (max_h_m) is what keeps fretted notes in tune; a string that no
    # finger touches in this scene needs only the dispersion criterion.
    fingered = any(e.type in FINGER_EVENTS for e in events)
    q_string = q if fingered else replace(q, max_h_m=math.inf)
    return (*oversample_for(spec, length, rate, q_string, rmax, comp), rmax)


def _finger_warnings(preset: Preset, string: int, events: list, model: StringModel,
                     tension_ratio: float) -> list[tuple[float, int, str]]:
    """``scene_warnings`` for one string's ``events``, on its grid ``model`` at ``tension_ratio``
    times its tuned tension: (time, string, message) of each finger pressing too lightly."""
    out = []
    for e in events:
        if e.type not in FINGER_EVENTS or e.force is None:
            continue
        frets = frets_pressed(e)
        if frets.start < 1:
            continue  # fret 0 lifts the finger
        rests = max(seating_force(model, preset, f, tension_ratio) for f in frets)
        if e.force < SEAT_MARGIN * rests:
            kind = e.type.replace("_", "-")
            where = (f"frets {e.from_fret}-{e.to_fret}" if isinstance(e, Slide)
                     else f"fret {e.fret}")
            out.append((e.time, string, f"string {string}: the {kind} at {e.time:g} s presses "
                                        f"{e.force:g} N; holding the string on {where} takes "
                                        f"about {SEAT_MARGIN * rests:.1f} N (it rests on the "
                                        f"fret from {rests:.2f} N when still): the note may "
                                        "sound dead or buzz"))
    return out


def scene_warnings(scene: Scene, options: RenderOptions | None = None) -> list[str]:
    """What the scene asks for that may not sound as a player would mean it: a finger pressing
    with less than ``SEAT_MARGIN`` times the force at which its string rests on the fret at all
    (``intonation.seating_force``, on the string's grid as ``prepare`` builds it, at the highest
    tension the scene's bends give the string; a slide: the largest over the frets it crosses).
    Below that force rendered notes were found not to hold (``benchmarks/seating.py``): the finger
    pushes the string down without stopping it, and the note sounds dead or buzzes.  Fingers with
    no force of their own press hard enough (``intonation.press_force``).  In time order.  A
    prepared scene has the same list without building the grids again: ``Engine.warnings``."""
    opts = options or RenderOptions()
    preset = scene.preset()
    q = opts.quality or QUALITY[scene.quality]
    out = []
    for i in range(1, preset.n_strings + 1):
        events = events_on(scene, preset.n_strings, i)
        if any(e.type in FINGER_EVENTS and e.force is not None for e in events):
            _, model, ratio = string_model(preset, i, events, float(scene.sample_rate), q, opts)
            out += _finger_warnings(preset, i, events, model, ratio)
    return [text for _, _, text in sorted(out)]


def prepare(scene: Scene, options: RenderOptions | None = None) -> Engine:
    """Tune and grid every string, compile the controls, allocate state."""
    opts = options or RenderOptions()
    q = opts.quality or QUALITY[scene.quality]
    if opts.gamma_rule not in GAMMA_RULES:
        raise ValueError(f"gamma_rule must be one of {sorted(GAMMA_RULES)}")
    kc_tol = q.kc_tolerance if opts.kc_tolerance is None else opts.kc_tolerance
    if not kc_tol >= 0.0:
        raise ValueError("kc_tolerance must be >= 0")
    preset = scene.preset()
    rate = float(scene.sample_rate)
    out = scene.output
    if out.pickups:
        pickups = [p.position for p in out.pickups]
        gains = np.array([p.gain for p in out.pickups])
    else:
        pickups = [out.pickup_position or preset.pickup_position]
        gains = np.ones(1)
    nstr = preset.n_strings
    voices = []
    for i in range(1, nstr + 1):
        events = events_on(scene, nstr, i)
        if opts.skip_silent and not events:
            continue
        os_, model, rmax = string_model(preset, i, events, rate, q, opts)
        fret_mode = q.fret_mode if opts.frets else 0
        coefs = coefficients(model, preset, fret_mode, opts.kirchhoff_carrier, opts.fretboard)
        coefs = coefs._replace(gamma_rule=GAMMA_RULES[opts.gamma_rule],
                               kc_s_skip=kc_skip_level(model, kc_tol))
        impedance = math.sqrt(model.tension_n * model.rho_a)
        calibrate = q.calibrate_frets if opts.calibrate_frets is None else opts.calibrate_frets
        shifts = (fret_shifts(model, preset, stopped_frets(events))
                  if calibrate and fret_mode == FRET_RIGID else None)
        ctl = string_controls(events, preset, i, model.h, model.n, rate * os_, impedance,
                              partial(tension_ratio_for_cents, model), shifts,
                              partial(press_force, model, preset, tension_ratio=rmax))
        margin = (fret_margin(model, preset, ctl.max_pluck_force, ctl.fingers)
                  if opts.skip_contacts else 1.0)
        geom = geometry(model, preset, pickups, with_frets=fret_mode != 0, margin=margin,
                        fretboard=opts.fretboard, quiet=opts.skip_contacts, fret_shifts=shifts,
                        held=opts.held_steps)
        voices.append(Voice(i, model, coefs, geom, ctl, gains, os_, Decimator(os_, rate),
                            scene.diagnostics, opts.skip_decayed, opts.decay_velocity, rmax))
    frames = frame_count(scene)
    pan = out.pan or default_pan(nstr)
    body_name = out.body or preset.body
    body = Body(body_name, rate, out.channels) if body_name != "none" else None
    return Engine(scene, preset, voices, opts, frames, out.channels,
                  {i + 1: pan_gains(p) for i, p in enumerate(pan)}, body)


__all__ = ["Engine", "FIXED_GAIN", "frame_count", "QUALITY", "Quality", "RenderOptions", "prepare",
           "FRET_PENALTY", "FRET_RIGID", "scene_warnings"]
