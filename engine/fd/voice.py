"""One string of a scene: its grid, coefficients, controls and the state carried across blocks.

A ``Voice`` is what ``engine.fd.instrument`` builds per string that needs simulating: the string tuned on
the grid its quality asks for (``string_model``, ``oversample_for``), the kernel's inputs
(``engine.fd.string``, ``engine.fd.controls``), the state ``kernels.step_block`` advances, and the
energy series of the discrete balance (paper sec. 6.1) when diagnostics are on.  It also owns the
last skip of the render: a string whose motion has decayed below ``decay_velocity`` after its
last event stops being computed, and one that has decayed so before its next event sleeps until
then (a long song's strings are computed while they sound, not between their notes).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from functools import partial

import numpy as np

from ..instrument import DECAY_CHECK_FRAMES
from ..options import Quality, RenderOptions
from ..output import Decimator
from ..performance import FINGER_EVENTS, max_tension_ratio
from ..presets import Preset
from ..scene import MAX_BEND_SEMITONES
from . import kernels
from .controls import NEVER, StringControls
from .string import StringModel, dispersion_cents, tension_ratio_for_cents, tune

SLEEP_MIN_STEPS = 4096  # a string sleeps only through a longer stillness (not worth it below)


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


def string_model(preset: Preset, string: int, events: list, rate: float, q: Quality,
                 opts: RenderOptions) -> tuple[int, StringModel, float]:
    """The internal oversampling factor, the tuned string on its grid for ``events`` (those on
    ``string``), built for the highest tension the scene's bends reach, and that tension over the
    tuned one.  ``opts.live_grid``: for any events (fingered, the largest bend allowed)."""
    spec = preset.strings[string - 1]
    length = preset.string_length_m(string)
    comp = opts.compensate_dispersion
    probe = tune(spec, length, rate, q.grid_scale, comp)
    rmax = max_tension_ratio(events, partial(tension_ratio_for_cents, probe))
    if opts.live_grid:  # any event may come: the largest bend the schema allows
        rmax = max(rmax, tension_ratio_for_cents(probe, 100.0 * MAX_BEND_SEMITONES))
    if opts.oversample:
        return (opts.oversample,
                tune(spec, length, rate * opts.oversample, q.grid_scale, comp, rmax), rmax)
    # The contact resolution (max_h_m) is what keeps fretted notes in tune; a string that no
    # finger touches in this scene needs only the dispersion criterion.
    fingered = opts.live_grid or any(e.type in FINGER_EVENTS for e in events)
    q_string = q if fingered else replace(q, max_h_m=math.inf)
    return (*oversample_for(spec, length, rate, q_string, rmax, comp), rmax)


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
    policy: kernels.Policy
    tension_ratio: float = 1.0  # the highest the scene's bends reach, over the tuned tension
    energy_series: bool = False  # keep the per-step series (else running figures only)
    # events (on this string, sorted) -> (controls, geometry) on this grid (``instrument.prepare``):
    # a live session recompiles them as events arrive
    rebuild: object = field(default=None, repr=False)
    step: int = 0
    stopped: bool = False
    asleep_until: int = 0  # no step before this is computed (the string is still, nothing acts)
    steps_computed: int = 0
    _decay_peak: float = 0.0  # largest |pickup output| since the last decay check
    energy_h: list = field(default_factory=list)
    energy_q: list = field(default_factory=list)
    energy_p: list = field(default_factory=list)
    _step_block: object = field(default=None, repr=False)  # kernels.entry_point of step_block
    # every step at which a control acts or changes, sorted, and the controls they are of
    _changes: np.ndarray = field(default=None, repr=False)
    _changes_of: object = field(default=None, repr=False)

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
        # running figures of the balance, so that a long render keeps no per-step series
        self._h_last = self.h_start  # the last H stored
        self._h_max = 0.0  # max |H|
        self._dev_max = 0.0  # max |H^(n+1/2) - H^(n-1/2) + k Q^n - k P^n|

    @property
    def u(self) -> np.ndarray:
        return self.state.u

    @property
    def u1(self) -> np.ndarray:
        return self.state.u1

    def frames(self, end: int) -> np.ndarray:
        """The pickup velocity at the output rate up to output frame ``end``: the string run
        until ``Decimator.lead`` steps past that frame's step, and decimated.  A stopped string
        whose filter holds nothing gives zeros without running the filter."""
        nsteps = end * self.oversample + self.decimator.lead - self.step
        d = self.decimator
        if self.stopped and (d.factor == 1 or not d.history.any()):
            self.step += nsteps
            return d.skip(nsteps)
        return d(self.run(nsteps))

    def run(self, nsteps: int) -> np.ndarray:
        """Advance nsteps internal steps; return the pickup mix at the internal rate.

        With the decay skip on, the steps are run in pieces that end on the global step grid of
        ``DECAY_CHECK_FRAMES`` output frames, and the string is tested for decay (to stop, or to
        sleep until its next control change) only there: so where it stops or sleeps does not
        depend on how the caller cuts the render into blocks (a stream's blocks and a whole render
        give the same samples)."""
        if self.stopped or nsteps == 0 or self.step + nsteps <= self.asleep_until:
            self.step += nsteps
            return np.zeros(nsteps)
        if self.step < self.asleep_until:  # wakes within this block
            quiet = self.asleep_until - self.step
            self.step = self.asleep_until
            return np.concatenate((np.zeros(quiet), self.run(nsteps - quiet)))
        d = self.diagnostics
        if not self.skip_decayed or d:
            return self.pickup_gains @ self._steps(nsteps)
        period = DECAY_CHECK_FRAMES * self.oversample
        mix = np.zeros(nsteps)
        done = 0
        while done < nsteps and not self.stopped and self.step >= self.asleep_until:
            n = min(nsteps - done, period - self.step % period)
            out = self._steps(n)
            mix[done:done + n] = self.pickup_gains @ out
            done += n
            if out.size:
                self._decay_peak = max(self._decay_peak, float(np.max(np.abs(out))))
            if self.step % period == 0:
                if self.step > self.ctl.last_step:
                    self._maybe_stop(self._decay_peak)
                else:
                    self._maybe_sleep(self._decay_peak)
                self._decay_peak = 0.0
        rest = nsteps - done
        if rest and not self.stopped and self.step < self.asleep_until:
            mix[done:] = self.run(rest)  # asleep: silence until it wakes, then on
        else:
            self.step += rest  # stopped: the rest is silence
        return mix

    def _steps(self, nsteps: int) -> np.ndarray:
        """Run the kernel for nsteps steps; the output of each pickup at the internal rate."""
        self.steps_computed += nsteps
        out = np.zeros((len(self.pickup_gains), nsteps))
        d = self.diagnostics
        e_h = np.empty(nsteps if d else 0)
        e_q = np.empty(nsteps if d else 0)
        e_p = np.empty(nsteps if d else 0)
        args = (self.coefs, self.geom, self.ctl.arrays, self.state, self.policy, self.step, nsteps,
                out, d, e_h, e_q, e_p)
        if self._step_block is None:  # the argument types are the same in every block
            self._step_block = kernels.entry_point(kernels.step_block, args)
        status = self._step_block(*args)
        if status != kernels.OK:
            raise FloatingPointError(f"string {self.index}: the simulation became non-finite")
        self.step += nsteps
        if d and nsteps:
            hprev = np.concatenate(([self._h_last], e_h[:-1]))
            self._dev_max = max(self._dev_max, float(np.max(np.abs(e_h - hprev + e_q - e_p))))
            self._h_max = max(self._h_max, float(np.max(np.abs(e_h))))
            self._h_last = e_h[-1]
            if self.energy_series:
                self.energy_h.append(e_h)
                self.energy_q.append(e_q)
                self.energy_p.append(e_p)
        return out

    def _next_change(self) -> int:
        """The first step from now at which a control acts or changes (a pluck starts or ends, a
        finger is put down, moves or lifts, a damper comes or goes, a tension breakpoint).  Asked
        at every decay check, so the steps are sorted once per controls (a live session's
        ``rebuild`` gives new ones) and looked up by bisection."""
        a = self.ctl.arrays
        if self._changes_of is not a:
            self._changes = np.unique(np.concatenate(
                [np.asarray(x, np.int64) for x in (a.pl_start, a.pl_start + a.pl_len, a.fs_on,
                                                   a.fs_rel, a.fs_ms, a.fs_me, a.dp_on, a.dp_off,
                                                   a.tb_step)]))
            self._changes_of = a
        i = int(np.searchsorted(self._changes, self.step))  # the first at or after this step
        return int(self._changes[i]) if i < len(self._changes) else NEVER

    def _maybe_sleep(self, peak: float) -> None:
        # As _maybe_stop, until the next change: the string (and any finger resting on it) is
        # still, so nothing would happen before then but the decay of motion below
        # decay_velocity; the state is kept and the string resumes at that step.
        wake = self._next_change()
        if wake - self.step < SLEEP_MIN_STEPS:
            return
        st = self.state
        active = st.f_state == kernels.ACTIVE
        if np.any(self.ctl.arrays.fs_rel[active] < self.step):  # a finger lifting away
            return
        if self._still(peak):
            self.asleep_until = wake

    def _maybe_stop(self, peak: float) -> None:
        # Nothing will act on the string again (no event pending; a finger still on the string
        # holds still), so stop once every node, every finger and the pickups move slower than
        # decay_velocity.  A finger with a release still to come keeps the string running.
        st = self.state
        active = st.f_state == kernels.ACTIVE
        if np.any(self.ctl.arrays.fs_rel[active] < NEVER):
            return
        if self._still(peak):
            self.stopped = True

    def _still(self, peak: float) -> bool:
        """Every node, every finger on the string and the pickups (their largest output since the
        last check: ``peak``) slower than decay_velocity."""
        st = self.state
        active = st.f_state == kernels.ACTIVE
        k = self.coefs.k
        vmax = np.max(np.abs(st.u - st.u1)) / k
        if np.any(active):
            vmax = max(vmax, float(np.max(np.abs(st.f_w[active] - st.f_w1[active]))) / k)
        return bool(vmax < self.decay_velocity and peak < self.decay_velocity)

    def energy_error(self) -> float:
        """Largest relative energy-balance deviation (paper sec. 6.1):

        max_n |H^(n+1/2) - H^(n-1/2) + k Q^n - k P^n| / [max H]_2,
        with [.]_2 the nearest power of two below (the paper normalises by H^(1/2), which is zero
        for a string that starts at rest and is plucked; the largest stored energy is the scale).
        """
        if self._h_max == 0.0:
            return 0.0
        scale = 2.0 ** math.floor(math.log2(self._h_max))
        return self._dev_max / scale
