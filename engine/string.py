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
from dataclasses import dataclass
from functools import partial

import numpy as np

from .kernels import Coefs, Geo, interp
from .presets import Preset, StringSpec

# 60 dB of amplitude: exp(-sigma T60) = 1e-3, so sigma = 3 ln(10) / T60.  (Bilbao 2009 writes
# 6 ln(10) / T60; measured on rendered audio that halves the decay time: tests/engine/test_string.py)
LN1000 = 3.0 * math.log(10.0)

FRET_NONE, FRET_RIGID, FRET_PENALTY = 0, 1, 2


def loss_coefficients(spec: StringSpec, tension: float) -> tuple[float, float]:
    """sigma_0, sigma_1 matching T60 at the fundamental and at 2 kHz (two-frequency calibration)."""
    rho_a = spec.linear_density_kg_m
    gamma2 = tension / rho_a
    kappa2 = spec.youngs_modulus_pa * math.pi * spec.radius_m**4 / 4.0 / rho_a

    def xi(f: float) -> float:  # beta^2 of the mode at frequency f (continuous dispersion)
        w = 2.0 * math.pi * f
        return (-gamma2 + math.sqrt(gamma2**2 + 4.0 * kappa2 * w * w)) / (2.0 * kappa2)

    f1, f2 = spec.frequency_hz, 2000.0
    x1, x2 = xi(f1), xi(f2)
    t1, t2 = spec.t60_fundamental_s, spec.t60_2khz_s
    sigma1 = LN1000 * (1.0 / t2 - 1.0 / t1) / (x2 - x1)
    sigma1 = max(sigma1, 0.0)
    sigma0 = max(LN1000 / t1 - sigma1 * x1, 0.0)
    return sigma0, sigma1


def h_min(k: float, tension: float, rho_a: float, ei: float, sigma1: float) -> float:
    """The stability bound of eq. (47)."""
    a = tension * k / rho_a + 4.0 * sigma1
    return math.sqrt(0.5 * k * (a + math.sqrt(a * a + 16.0 * ei / rho_a)))


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
        return self.spec.youngs_modulus_pa * math.pi * self.spec.radius_m**4 / 4.0

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
    f_n at the model's tension."""
    return max(abs(1200.0 * math.log2(model.frequency(m) / model.target_frequency(m)))
               for m in range(1, partials + 1))


PINNED_PARTIAL = 10


def tune(spec: StringSpec, length: float, sample_rate: float, grid_scale: float = 1.0,
         compensate: bool = True, max_tension_ratio: float = 1.0) -> StringModel:
    """Build the string at internal rate ``sample_rate``, tuned so mode 1 sounds at spec's pitch.

    The explicit scheme's numerical dispersion flattens the upper partials (by about 1.5 cents at the
    10th on the B string at 44.1 kHz, and it shrinks only slowly with oversampling because h scales
    as sqrt(k) for a stiff string).  With ``compensate`` the scheme's tension *and* its bending
    stiffness are solved from its own dispersion relation so that modes 1 and ``PINNED_PARTIAL``
    land on the continuous string's frequencies (physical E I); the partials between follow within
    a fraction of a cent (tests/engine/test_string.py).  ``grid_scale`` >= 1 makes the grid coarser
    than the stability bound (h = grid_scale * h_min), a knob of the accuracy/cost study.
    ``max_tension_ratio`` > 1 keeps the grid stable up to that multiple of the tension (bends).
    """
    k = 1.0 / sample_rate
    rho_a = spec.linear_density_kg_m
    ei_phys = spec.youngs_modulus_pa * math.pi * spec.radius_m**4 / 4.0
    f0 = spec.frequency_hz
    tension = rho_a * (2.0 * length * f0) ** 2
    sigma0, sigma1 = loss_coefficients(spec, tension)
    scale = 1.0
    n = max(int(length / (grid_scale * h_min(k, tension * max_tension_ratio, rho_a, ei_phys,
                                               sigma1))), 4)
    for _ in range(60):
        for _ in range(8):  # alternate: tension for mode 1, stiffness for the pinned mode
            sigma0, sigma1 = loss_coefficients(spec, tension)
            args = (n, length, k, rho_a, sigma0, sigma1)
            tension = _secant(partial(_mode_error, 1, f0, args, ei_phys * scale, None), tension)
            if not compensate:
                break
            target = StringModel(spec, length, k, n, tension, sigma0, sigma1, scale
                                 ).target_frequency(PINNED_PARTIAL)
            scale = _secant(partial(_mode_error, PINNED_PARTIAL, target, args, ei_phys, tension),
                            scale)
        model = StringModel(spec, length, k, n, tension, sigma0, sigma1, scale)
        bound = h_min(k, tension * max_tension_ratio, rho_a, model.ei, sigma1)
        if length / n >= bound * (1.0 + 1e-12):
            return model
        n -= 1
    raise ValueError(f"cannot place a stable grid on string {spec.note}")


def _mode_error(mode, target, args, ei, tension, x):
    """Scheme frequency of ``mode`` minus target, as a function of the tension (tension None) or
    of the stiffness scale x (E I = ei * x)."""
    n, length, k, rho_a, sigma0, sigma1 = args
    if tension is None:
        return scheme_frequency(mode, n, length, k, x, rho_a, ei, sigma0, sigma1) - target
    return scheme_frequency(mode, n, length, k, tension, rho_a, ei * x, sigma0, sigma1) - target


def _secant(err, x0: float) -> float:
    """Root of err near x0 (err is smooth and monotonic here)."""
    x1 = x0 * 1.01
    e0, e1 = err(x0), err(x1)
    for _ in range(60):
        if e1 == e0:
            break
        x2 = x1 - e1 * (x1 - x0) / (e1 - e0)
        x0, e0 = x1, e1
        x1, e1 = x2, err(x2)
        if abs(e1) < 1e-13 * max(abs(x1), 1.0) * 1e3:
            break
    return x1


def coefficients(model: StringModel, preset: Preset, fret_mode: int,
                 kirchhoff_carrier: bool = True, fretboard: bool = True) -> Coefs:
    """The kernel's constants, eqs. (50a)-(52) written as stencils."""
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
        board_k=preset.fretboard_stiffness if fretboard else 0.0,
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


def fret_margin(model: StringModel, max_pluck_force: float) -> float:
    """How far above a fret tip a node of u^n must be for that fret to be out of reach next step.

    A point force f on a string moves it at most at f / (2 sqrt(T rho A)) (the string's wave
    impedance); three times that speed for one step, plus 50 um, bounds the motion with a wide
    margin.  tests/engine/test_skips.py checks that the skip leaves the output bit-identical.
    """
    z = math.sqrt(model.tension_n * model.rho_a)
    return 3.0 * max_pluck_force / (2.0 * z) * model.k + 50e-6



def geometry(model: StringModel, preset: Preset, pickups: list[float], with_frets: bool = True,
             margin: float = math.inf) -> Geo:
    """m0_q (eq. (8)) and b(x) (eq. (7)) from the action: the string's rest line rises linearly
    from ``action_nut_m`` above the fret crowns at the nut to ``action_12th_m`` at fret 12."""
    h, n = model.h, model.n
    q = np.arange(1, preset.frets + 1) if with_frets else np.arange(0)
    xq = preset.fret_x_m(q)
    p = np.empty(len(q), np.int64)
    w0 = np.empty(len(q))
    w1 = np.empty(len(q))
    for i, xf in enumerate(xq):
        p[i], w0[i], w1[i] = interp(xf, h, n)
    m0 = -np.asarray(preset.clearance_m(xq), dtype=float)
    xn = np.arange(1, n) * h
    board = -(np.asarray(preset.clearance_m(xn), dtype=float) + preset.fret_height_m)
    last = preset.fret_x_m(preset.frets + 0.5)  # the board ends half a fret past the last
    board[xn > last] = NO_BOARD
    near = np.full(n - 1, NO_BOARD)
    for i in range(len(q)):
        for node, w in ((p[i] - 1, w0[i]), (p[i], w1[i])):  # padded index -> node -> array index
            if w > 0.0:
                near[node - 1] = max(near[node - 1], m0[i] + margin)
    pk = [interp(x * model.length_m, h, n) for x in pickups]
    return Geo(board, near, p, w0, w1, m0, np.array([a[0] for a in pk], np.int64),
               np.array([a[1] for a in pk]), np.array([a[2] for a in pk]))
