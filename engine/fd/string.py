"""One string: the coefficients of the DAFx24 scheme from physical parameters, and its tuning.

* Loss: sigma_0, sigma_1 of eq. (3) from two 60 dB decay times (Bilbao, *Numerical Sound Synthesis*,
  2009, sec. 7.1.2): the decay rate of a mode of wavenumber beta is sigma_0 + sigma_1 beta^2.
* Grid: the stability bound eq. (47), h >= h_min; N = floor(L / h_min), h = L / N.
* Tuning: the tension is solved from the *scheme's own* dispersion relation (with its loss terms), so
  the simulated open string's fundamental is the nominal pitch to rounding, whatever the grid and the
  bending stiffness do to it.
* Geometry of the collisions: fret tips m0 (eq. (8)) and the fretboard b(x) (eq. (7)) from the
  preset's action; interpolants j^(x) (eq. (15)) for plucks, frets, fingers and the pickup.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache, partial

import numpy as np

from .. import calibration_store
from ..losses import loss_coefficients
from ..presets import Preset, StringSpec, get_preset
from .grid import MIN_NODES, h_min
from .kernels import Coefs, Geo, interp

FRET_NONE, FRET_RIGID, FRET_PENALTY = 0, 1, 2
# ``engine.options.FRET_MODES`` by name
FRET_MODE_CODES = {"none": FRET_NONE, "rigid": FRET_RIGID, "penalty": FRET_PENALTY}


def scheme_frequency(mode: int, n: int, length: float, k: float, tension: float, rho_a: float,
                     ei: float, sigma0: float, sigma1: float) -> float:
    """Frequency (Hz) of mode ``mode`` of the discrete lossy scheme (roots of z^2 - b z - c)."""
    h = length / n
    lam = 4.0 / (h * h) * math.sin(mode * math.pi / (2 * n)) ** 2  # eigenvalue of -D
    den = 1.0 + sigma0 * k
    b = (2.0 - (tension * k * k / rho_a) * lam - (ei * k * k / rho_a) * lam * lam
         - 2.0 * sigma1 * k * lam) / den
    c = (sigma0 * k - 1.0 + 2.0 * sigma1 * k * lam) / den
    disc = b * b + 4.0 * c
    if disc >= 0.0:
        return 0.0
    return math.atan2(math.sqrt(-disc), b) / (2.0 * math.pi * k)


@dataclass(frozen=True)
class StringModel:
    """A tuned string on its grid: everything the kernel needs except the per-scene controls."""

    spec: StringSpec
    length_m: float
    k: float
    n: int
    tension_n: float
    sigma0: float
    sigma1: float
    ei_scale: float = 1.0  # simulated E I / physical E I (dispersion pre-compensation, see tune)

    @property
    def h(self) -> float:
        return self.length_m / self.n

    @property
    def rho_a(self) -> float:
        return self.spec.linear_density_kg_m

    @property
    def ei_physical(self) -> float:
        return self.spec.bending_stiffness_nm2

    @property
    def ei(self) -> float:
        """The bending stiffness the scheme uses."""
        return self.ei_physical * self.ei_scale

    @property
    def ea(self) -> float:
        return self.spec.youngs_modulus_pa * self.spec.area_m2

    def frequency(self, mode: int = 1) -> float:
        return scheme_frequency(mode, self.n, self.length_m, self.k, self.tension_n, self.rho_a,
                                self.ei, self.sigma0, self.sigma1)

    def inharmonicity(self) -> float:
        """B = pi^2 E I / (T L^2) of f_n = n f0 sqrt(1 + B n^2), with the physical E I."""
        return math.pi**2 * self.ei_physical / (self.tension_n * self.length_m**2)

    def target_frequency(self, mode: int) -> float:
        """The continuous stiff string's f_n = n f0 sqrt(1 + B n^2), f0 = sqrt(T / rho A) / 2L."""
        f0 = math.sqrt(self.tension_n / self.rho_a) / (2.0 * self.length_m)
        return mode * f0 * math.sqrt(1.0 + self.inharmonicity() * mode * mode)


def tension_ratio_for_cents(model: StringModel, cents: float) -> float:
    """T'/T that moves the fundamental by ``cents``: f1^2 = (T + pi^2 E I / L^2) / (4 L^2 rho A)
    for the stiff string, so T(f) = 4 L^2 rho A f^2 - pi^2 E I / L^2."""
    L, ra = model.length_m, model.rho_a
    stiff = math.pi**2 * model.ei_physical / L**2
    f = model.spec.frequency_hz
    t0 = 4.0 * L * L * ra * f * f - stiff
    f1 = f * 2.0 ** (cents / 1200.0)
    return (4.0 * L * L * ra * f1 * f1 - stiff) / t0


def dispersion_cents(model: StringModel, partials: int = 10) -> float:
    """Largest |cents| between the scheme's modes 1..partials and the continuous stiff string's
    f_n at the model's tension; infinite when the grid has fewer modes or one of them does not
    oscillate (a partial the grid cannot carry is as far from f_n as it gets)."""
    worst = 0.0
    for m in range(1, partials + 1):
        f = model.frequency(m) if m < model.n else 0.0
        if f <= 0.0:
            return math.inf
        worst = max(worst, abs(1200.0 * math.log2(f / model.target_frequency(m))))
    return worst


PINNED_PARTIAL = 10
PARTIAL_LIMIT = 0.4  # x the sample rate: the highest frequency the compensation pins a partial at


def pinned_partial(model: StringModel, sample_rate: float) -> int:
    """The partial the dispersion compensation pins: ``PINNED_PARTIAL``, or the highest below it
    that the grid carries (mode < N) whose frequency f_n is at most ``PARTIAL_LIMIT`` x the rate
    (a high string at a low rate, or a very stiff one); 1 when none is (no compensation)."""
    for m in range(PINNED_PARTIAL, 1, -1):
        if m < model.n and model.target_frequency(m) <= PARTIAL_LIMIT * sample_rate:
            return m
    return 1




class _Untunable(ArithmeticError):
    """The compensated solve left the physical range (tension <= 0 or not finite)."""


@lru_cache(maxsize=512)  # a song asks the same strings again and again (frozen in, frozen out)
def tune(spec: StringSpec, length: float, sample_rate: float, grid_scale: float = 1.0,
         compensate: bool = True, max_tension_ratio: float = 1.0) -> StringModel:
    """Build the string at internal rate ``sample_rate``, tuned so mode 1 sounds at spec's pitch.

    The explicit scheme's numerical dispersion flattens the upper partials (by about 1.5 cents at the
    10th on the B string at 44.1 kHz, and it shrinks only slowly with oversampling because h scales
    as sqrt(k) for a stiff string).  With ``compensate`` the scheme's tension *and* its bending
    stiffness are solved from its own dispersion relation so that modes 1 and ``PINNED_PARTIAL``
    land on the continuous string's frequencies (physical E I); the partials between follow within
    a fraction of a cent (tests/engine/test_string.py).  When the 10th partial lies above
    ``PARTIAL_LIMIT`` x the rate (or the grid has fewer modes), the highest partial below that is
    pinned instead (``pinned_partial``).  The compensation never makes the stiffness negative (an
    almost flexible string near the Courant limit can be sharp; it keeps E I >= 0), and a string
    it cannot tune with a positive tension is built uncompensated.  ``grid_scale`` >= 1 makes the
    grid coarser than the stability bound (h = grid_scale * h_min), a knob of the accuracy/cost
    study.  ``max_tension_ratio`` > 1 keeps the grid stable up to that multiple of the tension
    (bends).

    The compensation raises E I, which coarsens the stable grid; when the grid is no longer stable
    it is rebuilt with the interval count the new bound allows (at least one fewer) and retuned.
    Raises ValueError for a string whose stiffness alone exceeds its pitch (no positive tension
    tunes it; ``engine.scene`` rejects such overrides) or that cannot get ``MIN_NODES`` intervals.

    Cached per process, and on disk per machine (``calibration_store``: exact to the bit), so that
    a process that finds its strings there neither solves them nor imports scipy's root finder.
    """
    def compute() -> tuple[float, ...]:
        m = _tune_any(spec, length, sample_rate, grid_scale, compensate, max_tension_ratio)
        return float(m.n), m.tension_n, m.sigma0, m.sigma1, m.ei_scale

    n, tension, sigma0, sigma1, scale = calibration_store.recall(
        "string_tuning", (spec, length, sample_rate, grid_scale, compensate, max_tension_ratio),
        compute)
    return StringModel(spec, length, 1.0 / sample_rate, int(n), tension, sigma0, sigma1, scale)


def _tune_any(spec, length, sample_rate, grid_scale, compensate, max_tension_ratio) -> StringModel:
    """``tune`` computed: compensated where it can be, else not."""
    if spec.stiffness_tension_n(length) >= spec.pitch_tension_n(length):
        raise ValueError(f"string {spec.note}: its bending stiffness alone exceeds its pitch "
                         "(pi^2 E I / L^2 >= 4 L^2 rho A f0^2): no positive tension tunes it")
    if compensate:
        try:
            return _tune(spec, length, sample_rate, grid_scale, True, max_tension_ratio)
        except _Untunable:
            pass
    try:
        return _tune(spec, length, sample_rate, grid_scale, False, max_tension_ratio)
    except _Untunable:
        raise ValueError(f"string {spec.note}: no positive tension tunes it on the grid") from None


def _tune(spec, length, sample_rate, grid_scale, compensate, max_tension_ratio) -> StringModel:
    k = 1.0 / sample_rate
    rho_a = spec.linear_density_kg_m
    ei_phys = spec.bending_stiffness_nm2
    f0 = spec.frequency_hz
    tension = rho_a * (2.0 * length * f0) ** 2
    sigma0, sigma1 = loss_coefficients(spec, tension)
    scale = 1.0
    n = max(int(length / (grid_scale * h_min(k, tension * max_tension_ratio, rho_a, ei_phys,
                                               sigma1))), MIN_NODES)
    for _ in range(60):
        for _ in range(8):  # alternate: tension for mode 1, stiffness for the pinned mode
            sigma0, sigma1 = loss_coefficients(spec, tension)
            args = (n, length, k, rho_a, sigma0, sigma1)
            tension = _secant(partial(_mode_error, 1, f0, args, ei_phys * scale, None), tension)
            if not tension > 0.0 or not math.isfinite(tension):
                raise _Untunable
            if not compensate:
                break
            model = StringModel(spec, length, k, n, tension, sigma0, sigma1, scale)
            pinned = pinned_partial(model, sample_rate)
            if pinned == 1:
                scale = 1.0
                continue
            target = model.target_frequency(pinned)
            scale = _secant(partial(_mode_error, pinned, target, args, ei_phys, tension),
                            max(scale, 1.0))
            if not math.isfinite(scale):
                raise _Untunable
            scale = max(scale, 0.0)
        model = StringModel(spec, length, k, n, tension, sigma0, sigma1, scale)
        bound = h_min(k, tension * max_tension_ratio, rho_a, model.ei, sigma1)
        if length / n >= bound * (1.0 + 1e-12):
            return model
        n = min(n - 1, int(length / bound))
        if n < MIN_NODES:
            break
    raise ValueError(f"cannot place a stable grid on string {spec.note}")


def _mode_error(mode, target, args, ei, tension, x):
    """Scheme frequency of ``mode`` minus target, as a function of the tension (tension None) or
    of the stiffness scale x (E I = ei * x)."""
    n, length, k, rho_a, sigma0, sigma1 = args
    if tension is None:
        return scheme_frequency(mode, n, length, k, x, rho_a, ei, sigma0, sigma1) - target
    return scheme_frequency(mode, n, length, k, tension, rho_a, ei * x, sigma0, sigma1) - target


def _secant(err, x0: float) -> float:
    """Root of err near x0 by the secant method (err is smooth and monotonic here).  Where err is
    flat to machine precision before the step tolerance is met, scipy stops with a warning: that
    is the root to the last few ulps, and it is taken (``_tune`` checks that it is physical)."""
    from scipy import optimize  # here: half a second of import that a stored tuning never needs

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return optimize.newton(err, x0, x1=x0 * 1.01, tol=1e-12 * abs(x0), maxiter=60,
                               disp=False)


def coefficients(model: StringModel, preset: Preset, fret_mode: int,
                 kirchhoff_carrier: bool = True, fretboard: bool = True,
                 rigid_board: bool = False) -> Coefs:
    """The kernel's constants, eqs. (50a)-(52) written as stencils.  K_B is 0 without a fretboard
    and with a rigid one (which is no SAV column: ``geometry``)."""
    k, h, n = model.k, model.h, model.n
    rho_a = model.rho_a
    s0, s1 = model.sigma0, model.sigma1
    den = 1.0 + s0 * k
    lam2 = model.tension_n * k * k / (rho_a * h * h)
    mu2 = model.ei * k * k / (rho_a * h**4)
    sg = 2.0 * s1 * k / (h * h)
    finger = preset.finger
    return Coefs(
        n=n,
        k=k,
        h=h,
        lam=k * k / (rho_a * h * den),
        b0=(2.0 - 2.0 * lam2 - 6.0 * mu2 - 2.0 * sg) / den,
        b1=(lam2 + 4.0 * mu2 + sg) / den,
        b2=-mu2 / den,
        c0=(s0 * k - 1.0 + 2.0 * sg) / den,
        c1=-sg / den,
        ih2=1.0 / (h * h),
        kc=model.ea * h * h / (4.0 * model.length_m) if kirchhoff_carrier else 0.0,
        rho_a_h=rho_a * h,
        t0=model.tension_n,
        ei=model.ei,
        sigma0=s0,
        sigma1=s1,
        board_k=preset.fretboard_stiffness if fretboard and not rigid_board else 0.0,
        board_alpha=preset.fretboard_alpha,
        fret_mode=fret_mode,
        fret_k=preset.fret_stiffness,
        fret_alpha=preset.fret_alpha,
        fg_mass=finger.mass_kg,
        fg_k=finger.stiffness,
        fg_alpha=finger.alpha,
        fg_r=finger.damping_n_s_m,
        fg_lift=3e-3,
        lam2=lam2,
        den=den,
    )


NO_BOARD = -1.0  # a "fretboard" a metre below the string: unreachable


def fret_margin(model: StringModel, preset: Preset, max_pluck_force: float, fingers: Sequence,
                frame: Frame) -> float:
    """How far above a fret tip a node of u^n must be for that fret to be out of reach next step.

    The skip is exact if no node under a fret moves further than the margin in one step, i.e. if
    the margin is at least k v_max for a bound v_max on the speed of every node.  Each thing that
    moves the string is bounded below (damping, palm mutes, harmonic touches only slow it down; a
    bend changes the tension over whole steps and moves no node fast, which ``test_skips.py``
    checks).  Not bounded: a grid-scale (odd-even) chatter of nodes pressed into the fretboard,
    a numerical artefact of the contact, which a random sweep of 1500 stress scenes found twice
    (nodes alternating by 0.4-0.5 mm per step next to a fret).

    * plucks (every style, strums and the pluck of a pull-off): a point force f drives the string,
      two half-strings of wave impedance Z = sqrt(T rho A) each, at f / (2 Z); pulses that overlap
      in time add (``max_pluck_force`` is the largest sum, ``controls._peak_total_force``);
    * a finger (fret, tap, hammer-on, slide, and its lift) carries the string under it along at
      its own speed, and pushes it with its force.  Its mass m is pushed by its pressing (or
      lifting) force F and slowed by the string, so its kinetic energy is at most what it starts
      with plus the work of F along its travel D: v_f = sqrt(v0^2 + 2 F D / m).  D is the gap it
      falls through (a tap starts above the string) plus twice the deepest the string can be
      pressed (clearance + fret height, doubled for the finger's own compression and for a string
      that is above its rest line when the finger lands).  And like a pluck, the force F drives
      the string at F / (2 Z) wherever the string gives way before the finger does (a light or
      slack string, F >> T, is thrown around the frets far faster than the finger moves: the
      random stress test found strings of Z ~ 0.005 kg/s moving 1-10 mm in one step under a
      3-6 N finger).  The finger's term is v_f + F / (2 Z);
    * a slide moves the contact point along the string at g = |x1 - x0| / duration; the string
      under it changes height at g S, S its slope there: the kink F / T of the pressing force
      plus the dip between two fret crowns, (clearance + fret height) / (half the smallest fret
      spacing).

    v_max = v_plucks + the fastest finger; waves crossing or reflecting can add up to about twice
    a speed, so the margin is three times v_max for one step, plus 50 um.
    ``frame`` (``string.frame`` of the same model and preset) holds the depth and the dip.
    ``tests/engine/test_skips.py`` checks that the skip leaves the output bit-identical with 20 N
    plucks, pops and pull-offs, 5 m/s taps and hammer-ons, 10 N lifts, a slide over 19 frets in
    1 ms, a 3-semitone bend in one step, and a light string under two fingers.
    """
    z = math.sqrt(model.tension_n * model.rho_a)
    v = max_pluck_force / (2.0 * z)
    if fingers:
        m = preset.finger.mass_kg
        v += max(math.sqrt(f.v0 ** 2 + 2.0 * f.force * (f.gap + 2.0 * frame.depth) / m)
                 + f.force / (2.0 * z) + f.glide * (f.force / model.tension_n + frame.dip)
                 for f in fingers)
    return 3.0 * v * model.k + 50e-6


def kc_skip_level(model: StringModel, tolerance: float) -> float:
    """The S below which the Kirchhoff-Carrier tension rise E A S / (2 L h) is less than
    ``tolerance`` x T0 (the kernel's ``Coefs.kc_s_skip``; a relative tension change r moves the
    pitch by about 866 r cents).  S / h approximates the integral of u_x^2 (eq. (6))."""
    return tolerance * 2.0 * model.length_m * model.h * model.tension_n / model.ea


@dataclass(frozen=True, eq=False)
class Frame:
    """A string's geometry on its grid less what depends on the contact margin (``frame``): what
    compiling its events again (a live session's event, ``Voice.rebuild``) need not recompute.
    Its arrays are shared by every ``Geo`` it gives: the kernels only read them."""

    board: np.ndarray
    fret_p: np.ndarray
    fret_w0: np.ndarray
    fret_w1: np.ndarray
    fret_m0: np.ndarray
    out_p: np.ndarray
    out_w0: np.ndarray
    out_w1: np.ndarray
    nfret: int
    near_at: np.ndarray  # the array index of each node next to a fret (``Geo.near``)
    near_m0: np.ndarray  # and that fret's tip height
    rigid_board: bool  # the board's nodes are rigid constraints, within reach by ``Geo.bnear``
    depth: float  # ``fret_margin``'s
    dip: float

    def geo(self, margin: float = math.inf) -> Geo:
        """The geometry with ``near`` (and a rigid board's ``bnear``) ``margin`` above the
        obstacles."""
        near = np.full(len(self.board), NO_BOARD)
        np.maximum.at(near, self.near_at, self.near_m0 + margin)  # two frets may share a node
        bnear = (np.where(self.board > NO_BOARD, self.board + margin, NO_BOARD)
                 if self.rigid_board else self.board)
        return Geo(self.board, near, self.fret_p, self.fret_w0, self.fret_w1, self.fret_m0,
                   self.out_p, self.out_w0, self.out_w1, bnear, self.nfret)


def geometry(model: StringModel, preset: Preset, pickups: list[float], with_frets: bool = True,
             margin: float = math.inf, fretboard: bool = True,
             fret_shifts: dict[int, float] | None = None, rigid_board: bool = False) -> Geo:
    """m0_q (eq. (8)) and b(x) (eq. (7)) from the action (``frame``), with ``near`` where a rigid
    fret is within reach (its tip plus ``margin``)."""
    return frame(model, preset, pickups, with_frets, fretboard, fret_shifts,
                 rigid_board).geo(margin)


def frame(model: StringModel, preset: Preset, pickups: list[float], with_frets: bool = True,
          fretboard: bool = True, fret_shifts: dict[int, float] | None = None,
          rigid_board: bool = False) -> Frame:
    """m0_q (eq. (8)) and b(x) (eq. (7)) from the action: the string's rest line rises linearly
    from ``action_nut_m`` above the fret crowns at the nut to ``action_12th_m`` at fret 12.
    ``Frame.geo(margin)`` adds ``near``: where a rigid fret is within reach (its tip plus
    ``margin``).  Without ``fretboard`` the board is out of reach everywhere, so that no node
    counts as below it (the kernel forms no board column then, and quiet steps do not stop for
    it).  ``fret_shifts`` (fret -> metres, ``engine.fd.intonation.fret_shifts``) moves those
    frets' interpolants along the string; their heights stay those at x_q.  With ``rigid_board``
    (rigid frets only) the fretboard is one rigid constraint per node over it, after the frets
    (``Geo``), within reach where a node of u^n is below the board plus ``margin``
    (``Geo.bnear``)."""
    h, n = model.h, model.n
    q = np.arange(1, preset.frets + 1) if with_frets else np.arange(0)
    xq = preset.fret_x_m(q, model.spec)
    shifts = fret_shifts or {}
    p = np.empty(len(q), np.int64)
    w0 = np.empty(len(q))
    w1 = np.empty(len(q))
    for i, xf in enumerate(xq):
        p[i], w0[i], w1[i] = interp(xf + shifts.get(int(q[i]), 0.0), h, n)
    m0 = -np.asarray(preset.clearance_m(xq), dtype=float)
    xn = np.arange(1, n) * h
    board = -(np.asarray(preset.clearance_m(xn), dtype=float) + preset.fret_height_m)
    last = preset.fret_x_m(preset.frets + 0.5, model.spec)  # the board ends half a fret past the last
    board[xn > last] = NO_BOARD
    if not fretboard:
        board[:] = NO_BOARD
    near_at: list[int] = []
    near_m0: list[float] = []
    for i in range(len(q)):
        for node, w in ((p[i] - 1, w0[i]), (p[i], w1[i])):  # padded index -> node -> array index
            if w > 0.0:
                near_at.append(int(node) - 1)
                near_m0.append(float(m0[i]))
    pk = [interp(x * model.length_m, h, n) for x in pickups]
    nfret = len(q)
    rigid = rigid_board and with_frets
    if rigid:
        on = np.flatnonzero(board > NO_BOARD)  # array index j: node j + 1, padded j + 2
        if np.any(np.diff(on) != 1):  # the kernels index the board's nodes as one run
            raise ValueError("the fretboard must cover consecutive nodes")
        p = np.concatenate([p, on + 2])
        w0 = np.concatenate([w0, np.ones(len(on))])
        w1 = np.concatenate([w1, np.zeros(len(on))])
        m0 = np.concatenate([m0, board[on]])
    # ``fret_margin``'s depth (clearance plus fret height: the deepest a finger presses the
    # string) and the slope of the dip between two fret crowns
    qa = np.arange(preset.frets + 1)
    xa = preset.fret_x_m(qa, model.spec)
    depth = float(np.max(preset.clearance_m(xa))) + preset.fret_height_m
    dip = depth / (0.5 * float(np.min(np.diff(xa))))
    return Frame(board, p, w0, w1, m0, np.array([a[0] for a in pk], np.int64),
                 np.array([a[1] for a in pk]), np.array([a[2] for a in pk]), nfret,
                 np.array(near_at, np.int64), np.array(near_m0), rigid, depth, dip)


def tuned_tension(preset: str | Preset, string: int, sample_rate: float = 44100.0) -> float:
    """Tension (N) that tunes string ``string`` (1 = highest) of a preset to its nominal pitch on
    the grid of ``sample_rate`` Hz: the scheme's own dispersion relation is solved for it
    (``tune``), so it depends slightly on the rate.  The engine tunes each string of a scene this
    way at its internal (oversampled) rate."""
    p = get_preset(preset) if isinstance(preset, str) else preset
    if not 1 <= string <= p.n_strings:
        raise ValueError(f"string {string} outside 1..{p.n_strings} for {p.name}")
    return tune(p.strings[string - 1], p.string_length_m(string), float(sample_rate)).tension_n
