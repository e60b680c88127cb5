"""One waveguide string in a scene: its design, its state across blocks, and the changes of where
it is stopped (applied between kernel calls, at the exact step).

At a change of the stopping fret (``controls.Timeline.stops``):

* the termination's filters and pitch switch to the new loop's (``string.design_loop`` for the
  new speaking length, cached per fret) and the obstacles' heights are taken from the new rest
  line (``collision``, ``fingering.rest_height``);
* when the stop moves towards the nut (a finger lifts, a pull-off, a slide down), the part of the
  string that sounds again is put at rest on its rest line (its rails held garbage while cut off)
  and the whole string is released from the old rest line onto the new one: the displacement
  relative to the rest line changes by rest_old - rest_new, added half to each rail (a balanced
  displacement with no velocity, E&E eq. (12)), so the absolute displacement is continuous;
* when it moves towards the bridge, the cut-off part is simply no longer read; a striking finger
  (``tap``, ``hammer_on``) carries the string from the old rest line onto the new one.

Either move takes the time the finger needs at its speed (a tap's ``velocity``,
``LIFT_SPEED_M_S`` for a lift) to cover the depth of the fret's crown, at most ``RAMP_MAX_S``:
done at once, the corner at the crown would leave at any speed, far faster than the finger.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..config import entry_point
from ..instrument import DECAY_CHECK_FRAMES
from ..output import silence
from ..presets import Preset
from ..statics import PressedString
from . import kernel as K
from .collision import BOARD_RESTITUTION, FRET_RESTITUTION, REACH_EVERY
from .controls import NEVER, Timeline
from .fingering import (
    FRET_REFLECTION,
    finger_decay_db_s,
    finger_reflection,
    stopped_frequency,
)
from .glide import GLIDE_EVERY
from .pluck import J_STATE, MAX_MASS_RATIO, MAX_POINTS, max_damping, window
from .string import D_LOW, Loop, Physical, design_loop, grid_size, loop_partials

MAX_SECTIONS = 4
# the kernel's glide (and collision reach) updates restart on this global grid (and where the stop
# changes), where it also tests the decay stop
BLOCK_MULTIPLE = K.BLOCK
assert BLOCK_MULTIPLE == DECAY_CHECK_FRAMES, "the decay stop is tested where the FD voice's is"
assert BLOCK_MULTIPLE % GLIDE_EVERY == 0 and BLOCK_MULTIPLE % REACH_EVERY == 0
assert MAX_SECTIONS == K.MAX_SECTIONS
RELEASE_S = 0.002  # a contact (palm, harmonic touch, light finger) lets go over 2 ms
LIFT_SPEED_M_S = 1.0  # a lifting finger lets the string up at this speed
RAMP_MAX_S = 0.005  # the longest a move onto a new rest line takes
# the options a built string's ``_configure`` reads into the kernel's ``CONFIG`` (``set_switches``)
SWITCHES = ("skip_decayed", "decay_velocity", "steady_runs", "damper_bound", "damped_velocity")


def _part(name: str, key: int | str) -> property:
    """A row or a field of one of the kernel's arrays (``kernel.Wave``, ``kernel.Events``); a
    view made when it is read, so that a copy of the voice keeps it a view of the copy's array."""
    return property(lambda self: getattr(self, name)[key])


@dataclass
class WaveguideVoice:
    index: int  # 1-based string number
    preset: Preset
    phys: Physical
    timeline: Timeline
    rate: float
    pickups: list[float]  # x / L
    gains: np.ndarray
    intonation: str
    statics: PressedString  # the pressed string's statics (``fingering.finger_decay_db_s``)
    dispersion: bool = True
    collisions: bool = True
    glide: bool = True
    finger_damping: bool = True
    skip_decayed: bool = True
    decay_velocity: float = 1e-7
    steady_runs: bool = True  # steady junctions in plain runs (``kernel._steady``; exact)
    damper_bound: bool = True  # a damper's neighbours by the energy bound (``kernel._reach``)
    damped_velocity: float = 1e-4  # the damped rest's bound on the points (m/s; 0: no rest)
    step: int = 0
    stopped: bool = False
    oversample: int = 1  # runs at the scene's rate (the mixer asks every voice)
    loops: dict = field(default_factory=dict)
    _run: object = field(default=None, repr=False)  # engine.config.entry_point of run_block
    asleep_from: int = -1  # the step the string fell asleep at (``_sleep``; -1: awake)
    asleep_until: int = 0  # and the step it wakes at (``_wake``)
    steps_slept: int = 0  # the steps it slept and woke from (``tools.song_instructions``)
    # the kernel's arrays' rows and fields (``_part``)
    R, Mb = _part("rails", 0), _part("rails", 1)
    js_on, js_off, js_len, js_rel, js_np = (_part("slots", f) for f in K.SLOT.names)
    js_idx, js_f, js_mp, js_rho, js_kappa = (_part("points", f) for f in K.POINT.names)
    col_n, col_live, col_list, col_ref, col_cr, col_prev = (_part("colliders", f)
                                                            for f in K.COLLIDER.names)
    pk_n, pk_w = _part("pk", "n"), _part("pk", "w")
    pb_step, pb_f = _part("bends", "step"), _part("bends", "ratio")
    st = _part("carry", 0)  # the kernel's ``CARRY`` record

    def __post_init__(self):
        spec = self.preset.strings[self.index - 1]
        self.spec = spec
        self.open_loop = self.loop(None)
        self.n = grid_size(self.open_loop)
        self.p0 = self.open_loop.period
        n = self.n
        # the ring must hold the live rails, the history the termination reads and its delay
        dmax = 0.12 * self.p0 + 16.0 + K.HISTORY
        size = 1 << int(math.ceil(math.log2(n + dmax + 16)))
        self.rails = np.zeros((2, size))  # R and Mb (``_part``)
        self.dcap = float(size - n - 8)
        self.carry = np.zeros(1, K.CARRY)  # what the kernel carries from call to call
        self.st["fresh"] = 1  # the first call starts the kernel's schedules
        self.st["glide"] = 1.0
        length = self.phys.length_m
        self.x_step = length / (0.5 * self.p0)  # X, metres per grid step
        mu = self.phys.mu
        c = self.x_step * self.rate
        self.k0 = mu * c * c  # the tension that makes (3) the waveguide's own scheme: K0 = mu c^2
        self.z = mu * c
        self.x_k0 = self.x_step / self.k0
        self._slots(self.timeline.slots)
        # pickups
        self.pk = np.zeros(len(self.pickups), K.PICKUP)
        self.pk["g"] = self.gains
        for p, xp in enumerate(self.pickups):
            g = min(max(self.n_of(xp * length), 1.0), n - 1.0 - 1e-9)
            self.pk_n[p] = int(math.floor(g))
            self.pk_w[p] = g - self.pk_n[p]
        # collision points: every grid point under the neck, its obstacle's height from the
        # straight rest line and its restitution
        self._rests: dict = {}  # ``_rest_grid``
        self._fret_xs: dict = {}  # ``_fret_x``
        self._collision_points()
        self.segments = np.zeros(n // REACH_EVERY + 2, K.SEGMENT)  # the reach's scratch
        self.ramps = np.zeros(n, K.RAMP)  # a move onto a new rest line (``_change``)
        self.glide_k = (self.phys.ea / (2.0 * length * self.phys.tension_n) / self.x_step
                        if self.glide else 0.0)
        self._stops_and_pitch(self.timeline)
        self.change_i = 0
        self.stop_fret: int | None = None
        self.stop_held = False
        self.config = np.zeros(1, K.CONFIG)
        self._configs: dict = {}  # ``_configure``
        self._moves: dict = {}  # ``_change``: (old stop, new stop, n_t) -> the move's shape
        self._configure(None)
        self.st["n_t"] = self._place(self.open_loop)

    # -- the timeline ----------------------------------------------------------------------------
    def _slots(self, slots: list) -> None:
        """The junctions' arrays for the kernel, and their states at rest."""
        ns = len(slots)
        self.slots = np.zeros(ns, K.SLOT)
        self.js_on[:] = [s.on for s in slots]
        self.onsets = np.sort(self.js_on)  # in time order: where a sleeping string wakes
        self.js_off[:] = [s.off for s in slots]
        self.js_len[:] = [s.length for s in slots]
        # every contact lets go over its pulse's length, at least RELEASE_S
        self.js_rel[:] = np.maximum(self.js_len, max(int(round(RELEASE_S * self.rate)), 1))
        self.points = np.zeros((ns, MAX_POINTS), K.POINT)
        self.jst = np.zeros((ns, MAX_POINTS, J_STATE))
        # the points of each place a junction takes (``_points``), found once a place: a song's
        # string has thousands of junctions at a few (plucks at one position, damps behind a few
        # frets).  ``place[j]``: junction j's row of the places' tables (``places``' order)
        places: dict[tuple, int] = {}
        place = np.array([places.setdefault((s.window, s.width_m, s.x_m, s.force != 0.0),
                                            len(places)) for s in slots], np.int64)
        count = np.zeros(len(places), np.int64)
        index = np.zeros((len(places), MAX_POINTS), np.int64)
        weight = np.zeros((len(places), MAX_POINTS))
        for r, (kind, width_m, x_m, blow) in enumerate(places):
            pts = self._points(kind, width_m, x_m, blow)
            count[r] = len(pts)
            for k, (i, w) in enumerate(pts):
                index[r, k], weight[r, k] = i, w
        self.slots["npts"] = count[place]
        # every junction's points at once (junction j, point k < npts): m', rho, k' of
        # ``pluck._msd``, each from its junction's contact
        j, k = np.nonzero(np.arange(MAX_POINTS) < self.slots["npts"][:, None])
        w = weight[place[j], k]
        force = np.array([s.force for s in slots], float)[j]
        mass = np.array([s.mass for s in slots], float)[j]
        damping = np.array([s.damping for s in slots], float)[j]
        stiffness = np.array([s.stiffness for s in slots], float)[j]
        z, rate = self.z, self.rate
        pt = self.points
        pt["n"][j, k] = index[place[j], k]
        pt["f"][j, k] = w * force
        pt["mp"][j, k] = np.minimum(w * mass * rate / z, MAX_MASS_RATIO)
        pt["rho"][j, k] = np.minimum(w * damping / (2.0 * z), max_damping(rate))
        pt["kappa"][j, k] = w * stiffness / (4.0 * rate * z)

    def _points(self, kind: str, width_m: float, x_m: float, blow: bool
                ) -> list[tuple[int, float]]:
        """(grid index, weight) of the points of a junction of window ``kind`` (``Slot.window``)
        ``width_m`` wide at ``x_m``: a split contact's two points around x (one if x is on a
        point), a window's (``pluck.window``).  A ``blow`` (a junction with a force) at i moves
        the points i - 1 and i: its points are shifted by one to centre it on x."""
        if kind == "split":
            centre = self.n_of(x_m)
            i0 = int(math.floor(centre))
            pts = [(i0, 1.0 - (centre - i0)), (i0 + 1, centre - i0)]
            pts = [(i, w) for i, w in pts if w > 0.0]
        else:
            pts = window(kind, width_m, x_m, self.x_step, self.n_of)
        if blow:
            pts = [(i + 1, w) for i, w in pts]
        return pts

    def _stops_and_pitch(self, tl: Timeline) -> None:
        """The pitch ratio's breakpoints and the changes of the stop."""
        self.bends = np.zeros(len(tl.ratio_steps), K.BEND)
        self.bends["step"] = tl.ratio_steps
        self.bends["ratio"] = tl.ratios
        # (step, fret, strike, held): a finger resting on the fret damps the note, one sliding
        # past the crowns does not (``fingering``)
        self.changes = tl.stops(self.preset, self.spec)

    def rebuild(self, tl: Timeline) -> None:
        """Take a new timeline at the current step, keeping the string's state: a live session
        (``engine.live``) compiles a string's events again when one comes.  The new timeline
        must agree with the old one on everything before ``step`` (events are only added at or
        after it, or released after it); a junction keeps its state if its slot is still there
        (the same onset, place and contact), and a new one starts at rest.  Given so, the
        samples are those of a voice built with the whole timeline from the start, as long as
        every event acts at least ``kernel.LOOKAHEAD`` steps after the call that learns of it
        begins (``kernel``)."""
        def key(sl):
            return (sl.on, sl.length, sl.x_m, sl.mass, sl.stiffness, sl.damping, sl.force,
                    sl.width_m, sl.window)

        old = {}
        for j, sl in enumerate(self.timeline.slots):
            old.setdefault(key(sl), []).append(j)
        jst = self.jst
        self.timeline = tl
        self._slots(tl.slots)
        for j, sl in enumerate(tl.slots):
            rows = old.get(key(sl))
            if rows:
                self.jst[j] = jst[rows.pop(0)]
        self._stops_and_pitch(tl)
        self.change_i = int(np.searchsorted([c[0] for c in self.changes], self.step,
                                            side="left"))
        self.st["pb"] = self._pb_index()
        if self.asleep_from >= 0:  # asleep or stopped: it wakes at its next event, as in a
            # render, which knew that event when the string fell asleep (``_sleep``)
            self.asleep_until = self._next_event()
            self.stopped = self.asleep_until >= NEVER
            self.st["stopped"] = int(self.stopped)
        elif self.stopped:  # at rest from the start: it runs again, its schedules anew
            self.stopped = False
            self.st["stopped"] = 0
            self.st["fresh"] = 1

    # -- geometry -------------------------------------------------------------------------------
    def n_of(self, x_m: float) -> float:
        """Fractional grid index of the point x_m metres from the nut (measured from the bridge)."""
        return self.n - (self.phys.length_m - x_m) / self.x_step

    def x_of(self, n: np.ndarray) -> np.ndarray:
        return self.phys.length_m - (self.n - np.asarray(n, float)) * self.x_step

    def _collision_points(self) -> None:
        p = self.preset
        n = self.n
        if not self.collisions:
            idx = np.zeros(0, np.int64)
            board = np.zeros(0)
            cr = np.zeros(0)
        else:
            last = float(p.fret_x_m(p.frets + 0.5, self.spec))
            idx = np.arange(1, n)
            x = self.x_of(idx)
            keep = (x > 0.0) & (x <= last)
            idx, x = idx[keep], x[keep]
            board = -(np.asarray(p.clearance_m(x), float) + p.fret_height_m)
            cr = np.full(len(idx), BOARD_RESTITUTION)
            for q in range(1, p.frets + 1):
                xq = float(p.fret_x_m(q, self.spec))
                i = int(round(self.n_of(xq)))
                hit = np.flatnonzero(idx == i)
                if hit.size:
                    board[hit[0]] = max(board[hit[0]], -float(p.clearance_m(xq)))
                    cr[hit[0]] = FRET_RESTITUTION
        self.col_abs = board
        self.colliders = np.zeros(len(idx), K.COLLIDER)
        self.col_n[:] = idx
        self.col_ref[:] = board
        self.col_cr[:] = cr

    # -- configurations ---------------------------------------------------------------------------
    def loop(self, fret: int | None, held: bool = False) -> Loop:
        """The loop stopped at ``fret`` (None: open); ``held``: by a finger that stays there
        (``fingering.finger_reflection``)."""
        key = (fret, held)
        if key in self.loops:
            return self.loops[key]
        p = self.preset
        x = 0.0 if fret is None else float(p.fret_x_m(fret, self.spec))
        f1 = stopped_frequency(p, self.phys, self.index, x, fret, self.intonation,
                               p.finger.press_force_n)
        speaking = self.phys.length_m - x
        refl = 1.0
        if fret is not None:
            refl = FRET_REFLECTION
            if held and self.finger_damping:
                refl *= finger_reflection(
                    finger_decay_db_s(self.statics, p, self.index, self.rate, fret), f1)
        loop = design_loop(self.spec, self.phys, self.rate, f1, speaking, refl, self.dispersion)
        self.loops[key] = loop
        return loop

    def _configure(self, fret: int | None, held: bool = False) -> None:
        """The kernel's ``CONFIG`` record and the obstacles' heights for the stop at ``fret``:
        built once per stop and switch setting and copied in (a song changes the stop
        thousands of times among a few frets)."""
        key = (fret, held, self.decay_velocity, self.skip_decayed, self.steady_runs,
               self.damper_bound, self.damped_velocity)
        made = self._configs.get(key)
        if made is None:
            lp = self.loop(fret, held)
            cfg = np.zeros(1, K.CONFIG)
            c = cfg[0]
            c["n"], c["disp_m"], c["fs"], c["x_k0"] = self.n, lp.disp_m, self.rate, self.x_k0
            c["loss_g"], c["loss_a"] = lp.loss_g, lp.loss_a
            c["disp_a"], c["refl_g"], c["tau"] = lp.disp_a, lp.refl_g, lp.tau
            c["gain"], c["glide_k"] = lp.gain_bound, self.glide_k
            c["dcap"], c["fbase"] = self.dcap, self.rate / lp.period
            c["decay_v"] = self.decay_velocity if self.skip_decayed else 0.0
            # the damped rest (``kernel._settle``) holds the pickups to decay_velocity whether
            # or not the decay stop is on: it is part of the model, not a skip
            c["rest_v"] = self.decay_velocity if self.damped_velocity > 0.0 else 0.0
            c["damped_v"] = self.damped_velocity
            c["steady_runs"] = int(self.steady_runs)
            c["damper_bound"] = int(self.damper_bound)
            ref = self.col_abs - self._rest_grid(fret)[self.col_n] if len(self.col_n) else None
            made = (cfg.view(np.uint8), ref)
            self._configs[key] = made
        self.config.view(np.uint8)[:] = made[0]  # the record's bytes (a record copy is slow)
        self.stop_fret = fret
        self.stop_held = held
        if made[1] is not None:
            self.col_ref[:] = made[1]
            self.col_live[:] = 0

    def set_switches(self, **switches) -> None:
        """Set the skips' and the damped rest's switches (``SWITCHES``: the fields of the same
        names, which the kernel's ``CONFIG`` record carries) before the string has run, as
        ``WaveguideOptions`` would have (the tools that measure them render one prepared scene
        with each setting).  The other options shape the string as it is built, so they are not
        switches here."""
        for name, value in switches.items():
            if name not in SWITCHES:
                raise AttributeError(f"{name!r} is not a switch of a built string; the switches: "
                                     f"{', '.join(SWITCHES)}")
            setattr(self, name, value)
        self._configure(self.stop_fret, self.stop_held)

    def _pb_index(self) -> int:
        """The pitch breakpoint in force now (the last at or before ``step``; the kernel's
        ``carry.pb``)."""
        return max(int(np.searchsorted(self.pb_step, self.step, side="right")) - 1, 0)

    def _ratio_now(self) -> float:
        if len(self.bends) == 1:  # no bend or vibrato: one breakpoint
            return float(self.bends[0]["ratio"])
        s = self.step
        i = self._pb_index()
        if i + 1 < len(self.pb_step):
            a = (s - self.pb_step[i]) / (self.pb_step[i + 1] - self.pb_step[i])
            return float(self.pb_f[i] + a * (self.pb_f[i + 1] - self.pb_f[i]))
        return float(self.pb_f[i])

    def _place(self, lp: Loop) -> int:
        """The termination's grid index for loop ``lp`` now: D = P - 2 (N - n_t) - tau in
        [1, 3)."""
        period = lp.period / (self._ratio_now() * self.st["glide"])
        half = int(math.floor((period - lp.tau - D_LOW) / 2.0))
        return int(min(max(self.n - half, 0), self.n - 1))

    def partial_frequencies(self, count: int) -> np.ndarray:
        """Hz of the open string's partials 1..count from the loop's own phase (``string
        .loop_partials``: exact for the linear loop at rest, as the finite-difference model's
        dispersion relation is for its scheme)."""
        lp = self.open_loop
        nt = self._place(lp)
        d = min(max(lp.period - 2.0 * (self.n - nt) - lp.tau, D_LOW), self.dcap)
        return loop_partials(lp, 2 * (self.n - nt), d, count) * self.rate / (2.0 * math.pi)

    def _rest(self, fret: int | None, x: np.ndarray) -> np.ndarray:
        stop_x = None if fret is None else float(self.preset.fret_x_m(fret, self.spec))
        x = np.asarray(x, float)
        if stop_x is None:
            return np.zeros(len(x))
        # ``fingering.rest_height`` at every x, in the same arithmetic
        c = float(self.preset.clearance_m(stop_x))
        length = self.phys.length_m
        return np.where(x >= stop_x, -c * (length - x) / (length - stop_x), -c * x / stop_x)

    def _rest_grid(self, fret: int | None) -> np.ndarray:
        """``_rest`` at every grid point 0..N, kept per stop: a song changes the stop thousands of
        times among a few frets (elementwise the same values as ``_rest`` at any of them)."""
        grid = self._rests.get(fret)
        if grid is None:
            grid = self._rest(fret, self.x_of(np.arange(self.n + 1)))
            self._rests[fret] = grid
        return grid

    def _fret_x(self, fret: int | None) -> float:
        """The stop's place, metres from the nut (-1 for the open string), kept per fret."""
        x = self._fret_xs.get(fret)
        if x is None:
            x = -1.0 if fret is None else float(self.preset.fret_x_m(fret, self.spec))
            self._fret_xs[fret] = x
        return x

    def _change(self, fret: int | None, strike: float, held: bool) -> None:
        old = self.stop_fret
        if fret == old:
            if held != self.stop_held:  # a finger comes to rest on the fret or slides off it:
                self._configure(fret, held)  # only the termination's reflection changes
            return
        st = self.carry[0]  # (``st``, ``R``, ``Mb``: each a view made when it is read)
        s = self.step
        nt_old = int(st["n_t"])
        self._configure(fret, held)
        nt = self._place(self.loop(fret, held))
        release = self._fret_x(fret) < self._fret_x(old)
        if release and nt < nt_old:
            R, Mb = self.rails
            mask = len(R) - 1
            lo = max(nt - 8, nt - self.n)
            back = np.arange(lo, nt_old)  # the part cut off comes back at rest
            R[(s - back) & mask] = 0.0
            Mb[(s + back) & mask] = 0.0
        st["n_t"] = nt
        if release:  # the filters' memory belongs to the loop that was cut
            st["loss"] = 0.0
            st["ap_x"] = 0.0
            st["ap_y"] = 0.0
        if release or strike > 0.0:
            # the string moves from the old rest line to the new one at the finger's speed: the
            # displacement from the rest line changes by rest_old - rest_new over that time, in
            # equal steps with no velocity of their own (balanced, E&E eq. (12))
            move = self._moves.get((old, fret, nt))  # a song repeats a few moves
            if move is None:
                idx = np.arange(nt + 1, self.n)
                rest_old, rest_new = self._rest_grid(old), self._rest_grid(fret)
                delta = rest_old[nt + 1:self.n] - rest_new[nt + 1:self.n]
                depth = float(np.max(np.abs(delta))) if len(delta) else 0.0
                jumps = []
                for n_p, w in zip(self.pk_n, self.pk_w, strict=True):
                    j = rest_old[n_p:n_p + 2] - rest_new[n_p:n_p + 2]
                    jumps.append((1.0 - w) * j[0] + w * j[1] if n_p > nt else 0.0)
                move = (idx, delta, depth, np.array(jumps))
                self._moves[(old, fret, nt)] = move
            idx, delta, depth, jumps = move
            speed = strike if strike > 0.0 else LIFT_SPEED_M_S
            steps = int(min(max(round(depth / speed * self.rate), 1), RAMP_MAX_S * self.rate))
            # the kernel takes a step of the move before each of its next ``steps`` steps
            # (``kernel._ramp``): the pickups read the displacement from the rest line, so their
            # last reading moves with it, and they see the string's motion, not the change of
            # frame
            self.ramps["n"][:len(idx)] = idx
            self.ramps["d"][:len(idx)] = delta / steps
            self.pk["jump"] = jumps / steps
            st["ramp_n"] = len(idx)
            st["ramp_left"] = steps

    # -- running ---------------------------------------------------------------------------------
    def _next_event(self) -> int:
        """The first step from now at which something acts on the string: a junction starts, the
        stop changes, a pitch breakpoint (NEVER if none): where a sleeping string wakes."""
        s = self.step
        later = NEVER
        for steps in (self.onsets, self.pb_step):  # both in time order
            i = int(np.searchsorted(steps, s))  # the first at or after s
            if i < len(steps):
                later = min(later, int(steps[i]))
        changes, i = self.changes, self.change_i
        while i < len(changes) and changes[i][0] < s:
            i += 1
        if i < len(changes):
            later = min(later, changes[i][0])
        return later

    def _sleep(self) -> None:
        """The kernel found the string still with nothing to act on it for ``kernel.LOOKAHEAD``
        steps (``kernel._may_sleep``): it sleeps until its next event, its state kept as it is
        now, or stops for good when no event is left."""
        self.st["stopped"] = 0
        self.asleep_from = self.step
        wake = self._next_event()
        if wake >= NEVER:
            self.stopped = True
            self.st["stopped"] = 1
        self.asleep_until = wake

    def _wake(self) -> None:
        """Resume a sleeping string at ``asleep_until`` with the state it fell asleep with: the
        rails rotated by the steps it slept (u+(n) at step s is R[s - n], u-(n) is Mb[s + n]:
        rotating both by the same count moves every wave's sample to the new step), the filters'
        and junctions' states as they were."""
        slept = self.asleep_until - self.asleep_from
        k = slept % self.rails.shape[1]
        if k:  # np.roll's permutation of both rails, by slices
            self.rails[:] = np.concatenate((self.rails[:, -k:], self.rails[:, :-k]), axis=1)
        # the schedules go on on the global grid, as if the string had run (no change of the stop
        # or of the pitch came while it slept): the period exact now, a reach now
        self.st["fresh"] = 2
        self.st["restart"] = self.asleep_until // BLOCK_MULTIPLE * BLOCK_MULTIPLE
        self.asleep_from = -1
        self.steps_slept += slept

    def run(self, nsteps: int) -> np.ndarray:
        """Advance nsteps samples; the pickups' velocity mix (m/s).

        With the decay skip on, the kernel tests the string on the global grid of
        ``BLOCK_MULTIPLE`` samples, as the finite-difference voice does: a string whose every
        point and pickups move slower than ``decay_velocity``, with nothing to act on it for
        ``kernel.LOOKAHEAD`` steps, sleeps until its next event (``_next_event``) and costs
        nothing until then, or stops for good when no event is left.  The kernel's schedules
        carry from one call to the next (``kernel``), so any blocks give the same samples."""
        if self.stopped or self.step + nsteps <= self.asleep_until:
            self.step += nsteps
            return silence(nsteps)  # read-only: the mix skips it (``output.add_to_mix``)
        out = np.empty(nsteps)  # the kernel writes every sample it runs (``_advance``)
        self._advance(out)
        return out

    def _advance(self, out: np.ndarray) -> None:
        """Run len(out) samples into ``out`` (fewer if the string stops: the rest stays 0)."""
        nsteps = len(out)
        done = 0
        end = self.step + nsteps
        st = self.carry[0]  # a view: the fields written here are the kernel's
        changes = self.changes
        while done < nsteps and not self.stopped:
            if self.step < self.asleep_until:  # asleep: silence until it wakes
                m = int(min(nsteps - done, self.asleep_until - self.step))
                out[done:done + m] = 0.0
                self.step += m
                done += m
                continue
            if self.asleep_from >= 0:
                self._wake()
            # the kernel restarts its schedules where the stop changes and around a move onto a
            # new rest line (the same steps however the render is cut: ``kernel``)
            fresh = False
            while self.change_i < len(changes) and changes[self.change_i][0] <= self.step:
                _, fret, strike, held = changes[self.change_i]
                self._change(fret, strike, held)
                self.change_i += 1
                fresh = True
            nxt = changes[self.change_i][0] if self.change_i < len(changes) else NEVER
            m = int(min(nsteps - done, nxt - self.step))
            st["next_stop"] = nxt
            if fresh:
                st["fresh"] = 1
            args = (K.Wave(self.config, self.carry, self.rails, self.pk, self.colliders,
                           self.segments, self.ramps),
                    K.Events(self.slots, self.points, self.jst, self.bends), self.step,
                    out[done:done + m])
            if self._run is None:  # the argument types are the same in every call
                self._run = entry_point(K.run_block, args)
            ran = self._run(*args)
            if ran < 0:
                if ran == -2:
                    raise RuntimeError("the cached waveguide kernel was compiled with another "
                                       "REACH_EVERY: touch engine/waveguide/kernel.py")
                raise FloatingPointError(f"string {self.index}: the waveguide became non-finite")
            self.step += ran
            done += ran
            if st["stopped"]:
                self._sleep()
        if self.stopped:
            out[done:] = 0.0  # the rest is silence
        self.step = end

    def energy(self) -> float:
        """Stored energy of the sounding grid, J: each travelling wave's mu X (du/dt)^2 summed
        (kinetic plus potential energy of d'Alembert's waves; the terminations' filter states and
        the junctions' masses are not counted)."""
        mask = len(self.R) - 1
        s = self.step - 1
        nt = int(self.st["n_t"])
        idx = np.arange(nt, self.n + 1)
        # u+(n, s) - u+(n, s - 1) = R[s - n] - R[s - 1 - n]; u-: Mb[s + n] - Mb[s - 1 + n]
        dp = self.R[(s - idx) & mask] - self.R[(s - 1 - idx) & mask]
        dm = self.Mb[(s + idx) & mask] - self.Mb[(s - 1 + idx) & mask]
        return float(self.phys.mu * self.x_step * self.rate**2 * (np.sum(dp * dp)
                                                                  + np.sum(dm * dm)))
