"""A guitar of strings: the voices of one instrument, prepared from a scene and rendered block by block.

Each string is simulated on its own (the DAFx24 model has no coupling between strings) at an internal
rate ``oversample * sample_rate`` and decimated to the output rate by a linear-phase FIR filter whose
state is carried across blocks.  The output is the string *velocity* at the pickup point (m/s): it is
what a magnetic pickup senses and, like the bridge force that drives an acoustic top, it carries no
static offset when a finger presses the string down (a displacement output would jump by the
fretting depth).

Skips (each bounded by a test in ``tests/engine/test_skips.py`` and measured in ``benchmarks/``):
* a string with no events is never simulated (its output is exactly zero);
* contact work is done only where contact is possible: the linear pass counts the nodes within
  reach of the fretboard and of a fret tip (its height plus a bound on how far a node moves in
  one step, ``string.fret_margin``); a quiet step looks at the frets and the board's nodes only
  when they are within reach.  A finger's column is formed only while it exists, rigid frets and
  the rigid board's nodes only while active or within reach (the Hertzian fretboard's column
  only when a node is below the board, or a residual psi remains);
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
from dataclasses import dataclass
from functools import cache, partial

import numpy as np

from ..instrument import FINGERS, Instrument, is_lift, lift_kept, output_of
from ..options import FRET_MODES, GAMMA_RULES, QUALITY, RenderOptions
from ..output import Decimator
from ..performance import events_by_string
from ..presets import Preset
from ..scene import Bend, Harmonic, Mute, PullOff, Scene, Slide, Vibrato
from . import kernels
from .controls import stopped_frets, string_controls
from .intonation import fret_calibrations, fret_shifts, press_force
from .playability import finger_warnings, pull_off_warnings
from .string import (
    FRET_MODE_CODES,
    FRET_NONE,
    FRET_RIGID,
    Frame,
    coefficients,
    frame,
    fret_margin,
    kc_skip_level,
    tension_ratio_for_cents,
)
from .voice import Voice, string_model

# ``engine.options.GAMMA_RULES`` by name
GAMMA_CODES = {"joint": kernels.GAMMA_JOINT, "own": kernels.GAMMA_OWN, "paper": kernels.GAMMA_PAPER,
              "none": kernels.GAMMA_NONE}


@dataclass
class Guitar(Instrument):
    """A scene's guitar prepared for rendering (``engine.instrument.Instrument``): a ``Voice``
    for each string that needs simulating, the pickups' pan and the body (``engine.scene.Guitar``
    is its description in the scene)."""

    def voice_frames(self, voice: Voice, end: int) -> np.ndarray:
        return voice.frames(end)

    def energy_error(self) -> float:
        return max((v.energy_error() for v in self.voices), default=0.0)

    def warnings(self) -> list[str]:
        """``scene_warnings`` of the scene, on the grids its voices were built on (every string
        with a finger on it has a voice)."""
        n = self.preset.n_strings
        out = []
        by_string = events_by_string(self.scene, n)
        for v in self.voices:
            events = by_string[v.index]
            out += finger_warnings(self.preset, v.index, events, v.model, v.tension_ratio)
            out += pull_off_warnings(v.index, events)
        return [text for _, _, text in sorted(out)]

    # ---- live play (``engine.live``) ----------------------------------------------------------

    @property
    def live_delay(self) -> int:
        """A string's output frame m is centred on its internal step m f + (f - 1) / 2, and the
        decimation filter needs ``Decimator.lead`` steps past it, so when a block ends a string
        has been simulated ``lead`` steps (``ceil(lead / f)`` frames) beyond it: the largest over
        the strings (13 frames at factors 2 and 3: 0.3 ms at 44.1 kHz)."""
        return max((-(-v.decimator.lead // v.oversample) for v in self.voices), default=0)

    def tension_breakpoints(self, voice: Voice) -> tuple[np.ndarray, np.ndarray, int]:
        a = voice.ctl.arrays
        return a.tb_step, a.tb_ratio, voice.oversample

    def rebuild(self, voice: Voice, events: list, prune: bool) -> list:
        """Compile the string's controls and geometry again (``Voice.rebuild``, the function
        ``prepare`` uses), keeping its state; its fingers' slots in the state follow them when
        pruning drops some."""
        v = voice
        old = len(v.ctl.arrays.fs_on)
        keep = list(range(old))  # the old slot of each slot kept, in order
        if prune:
            events, keep = _prune(v, events, self.scene.sample_rate * v.oversample)
        ctl, geom = v.rebuild(events)
        new = len(ctl.arrays.fs_on)
        take = [k if k < old else -1 for k in keep] + [-1] * (new - len(keep))  # -1: a new slot
        if take != list(range(new)) or len(v.state.f_state) != new:  # (every old slot dropped:
            v.state = _with_slots(v.state, take)  # take is empty, and the state must shrink too)
        v.ctl, v.geom = ctl, geom
        v.stopped = False
        return events


def prepare(scene: Scene, options: RenderOptions | None = None) -> Guitar:
    """Tune and grid every string, compile the controls, allocate state."""
    opts = options or RenderOptions()
    q = opts.quality or QUALITY[scene.quality]
    if opts.gamma_rule not in GAMMA_RULES:
        raise ValueError(f"gamma_rule must be one of {sorted(GAMMA_RULES)}")
    if q.fret_mode not in FRET_MODES:
        raise ValueError(f"fret_mode must be one of {sorted(FRET_MODES)}")
    kc_tol = q.kc_tolerance if opts.kc_tolerance is None else opts.kc_tolerance
    if not kc_tol >= 0.0:
        raise ValueError("kc_tolerance must be >= 0")
    preset = scene.preset()
    rate = float(scene.sample_rate)
    out = output_of(scene, preset)
    pickups, gains = out.pickups, out.gains
    nstr = preset.n_strings
    policy = kernels.Policy(quiet=opts.skip_contacts, held=opts.skip_contacts and opts.held_steps)
    voices = []
    by_string = events_by_string(scene, nstr)
    for i in range(1, nstr + 1):
        events = by_string[i]
        if opts.skip_silent and not events:
            continue
        os_, model, rmax = string_model(preset, i, events, rate, q, opts)
        fret_mode = FRET_MODE_CODES[q.fret_mode] if opts.frets else FRET_NONE
        rigid_board = (fret_mode == FRET_RIGID and opts.fretboard
                       and (q.rigid_board if opts.rigid_board is None else opts.rigid_board))
        coefs = coefficients(model, preset, fret_mode, opts.kirchhoff_carrier, opts.fretboard,
                             rigid_board)
        coefs = coefs._replace(gamma_rule=GAMMA_CODES[opts.gamma_rule],
                               kc_s_skip=kc_skip_level(model, kc_tol))
        calibrate = q.calibrate_frets if opts.calibrate_frets is None else opts.calibrate_frets
        frets = range(1, preset.frets + 1) if opts.live_grid else stopped_frets(events)
        shifts = damping = None
        if calibrate and fret_mode == FRET_RIGID:
            if q.calibrate_damping if opts.calibrate_damping is None else opts.calibrate_damping:
                cal = fret_calibrations(model, preset, frets)
                shifts = {f: c.shift_m for f, c in cal.items()}
                damping = {f: c.damping_n_s_m for f, c in cal.items()}
            else:
                shifts = fret_shifts(model, preset, frets)
        # the default pressing force of each fret (a small static solve), once per string
        press = cache(partial(press_force, model, preset, tension_ratio=rmax))
        # the geometry less the contact margin, which the events set: once per string
        rest = frame(model, preset, pickups, with_frets=fret_mode != 0, fretboard=opts.fretboard,
                     fret_shifts=shifts, rigid_board=rigid_board)
        build = partial(_controls_and_geometry, preset, i, model, rate * os_, shifts, damping,
                        press, rest, opts)
        ctl, geom = build(events)
        voices.append(Voice(i, model, coefs, geom, ctl, gains, os_, Decimator(os_, rate),
                            scene.diagnostics, opts.skip_decayed, opts.decay_velocity, policy,
                            rmax, opts.energy_series, rebuild=build))
    return Guitar(scene, preset, voices, opts, out.frames, out.channels, out.pans, out.body)


def _controls_and_geometry(preset: Preset, i: int, model, rate: float, shifts, damping, press,
                           rest: Frame, opts: RenderOptions, events: list):
    """String ``i``'s control arrays for ``events`` (those on it, sorted) on the grid of ``model``
    at the internal ``rate``, and its geometry (``rest``, computed once a string) with the
    contact margin those events need."""
    impedance = math.sqrt(model.tension_n * model.rho_a)
    ctl = string_controls(events, preset, i, model.h, model.n, rate, impedance,
                          partial(tension_ratio_for_cents, model), shifts, press, damping)
    margin = (fret_margin(model, preset, ctl.max_pluck_force, ctl.fingers, rest)
              if opts.skip_contacts else 1.0)
    return ctl, rest.geo(margin)


def _prune(v: Voice, events: list, rate: float) -> tuple[list, list[int]]:
    """Drop the events whose effect is over at the voice's current step (``rate``: its steps per
    second): plucks whose pulse has ended, fret-0 lifts past with no finger kept that they may
    have lifted, dampers released, bends and vibratos when the tension is back at its tuned value
    for good, fingers whose slot is gone (and pull-offs of their fret).  The samples stay the
    same: the kernel skips all of these (a finished pluck adds nothing, a released damper and a
    gone finger form no column, a tension of exactly 1 gives the unbent stencil).  Returns the
    events kept and the old slot of each finger slot kept."""
    step = v.step
    arr = v.ctl.arrays
    tension_done = (arr.tb_step.size == 0
                    or (arr.tb_step[-1] < step and arr.tb_ratio[-1] == 1.0))
    keep_slots: list[int] = []
    kept_frets: set[int] = set()
    keep = [False] * len(events)
    slot = 0
    for i, e in enumerate(events):  # fingers first: their slots are the state's
        if isinstance(e, FINGERS) and not is_lift(e):
            if round(e.time * rate) >= step or v.state.f_state[slot] != kernels.GONE:
                keep[i] = True
                keep_slots.append(slot)
                kept_frets.add(e.to_fret if isinstance(e, Slide) else e.fret)
            slot += 1
    for i, e in enumerate(events):
        if keep[i]:
            continue
        if is_lift(e):
            keep[i] = lift_kept(e, events, keep, step, rate)
        elif isinstance(e, FINGERS):
            continue
        elif round(e.time * rate) >= step:
            keep[i] = True
        elif isinstance(e, Bend | Vibrato):
            keep[i] = not tension_done
        elif isinstance(e, Mute | Harmonic):
            keep[i] = e.release is None or round(e.release * rate) >= step
        elif isinstance(e, PullOff):
            keep[i] = e.fret in kept_frets
        else:  # a pluck: its pulse lasts at most 50 ms
            keep[i] = round(e.time * rate) + round(0.05 * rate) + 1 >= step
    return [e for e, k in zip(events, keep, strict=True) if k], keep_slots


def _with_slots(st: kernels.State, take: list[int]) -> kernels.State:
    """The state with its finger-slot arrays re-indexed: new slot j takes old slot take[j]
    (-1: a new slot, idle)."""
    idx = np.array(take, np.int64)
    new = idx < 0

    def pick(a: np.ndarray) -> np.ndarray:
        out = a[np.where(new, 0, idx)] if a.size else np.zeros(len(idx), a.dtype)
        out[new] = 0
        return out.astype(a.dtype)

    return st._replace(f_state=pick(st.f_state), f_w=pick(st.f_w), f_w1=pick(st.f_w1),
                       f_psi=pick(st.f_psi), f_bprev=pick(st.f_bprev))
