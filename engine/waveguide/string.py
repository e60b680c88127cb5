"""The waveguide string: two displacement-wave rails and the filters of its terminations.

Evangelista & Eckerholm 2010 (E&E), eq. (7): away from the junctions the string carries two
displacement waves that only travel, one grid step X = c T per sample,

    u(n, m) = u+(n, m) + u-(n, m),   u+(n + 1, m) = u+(n, m - 1),   u-(n - 1, m) = u-(n, m - 1).

Both rails are ring buffers indexed so that travelling is free: u+(n, m) = R[m - n] and
u-(n, m) = M[m + n] (``kernel``), so a sample costs the two terminations, the pickup and the
junctions that are active, whatever the string's length.

Grid.  The open string's loop (nut -> bridge -> nut) lasts P0 = fs / f0 samples at its nominal
pitch f0.  The grid holds N = floor((P0 - tau - 1) / 2) steps, tau the low-frequency delay of the
termination filters below; the rest of the loop is the termination's fractional delay D in [1, 3).
A point x metres from the nut sits at grid index n(x) = N - (L - x) / L * P0 / 2 (measured from
the bridge, where the pluck and the pickups are, at the open string's wave speed).

Terminations.  The bridge reflects with -1 (u(N) = 0).  Everything else the loop needs sits in the
other termination, the end of the speaking length nearer the nut (the nut itself, or the fret of a
stopped string, ``fingering``), at grid index n_t:

    u+(n_t, m) = -g_f * A_disp(z) * H_loss(z) * Lagrange_D(z) u-(n_t, m)

* Fractional delay: third-order Lagrange interpolation (FIR) reading the u- history at n_t, which
  is the rail itself (u-(n_t, m - j) = M[m + n_t - j]), with the delay D kept in [1, 3), where its
  taps interpolate around their centre and |H(e^jw)| <= 1 (passive).  Chosen over a Thiran allpass
  (the paper's first-order allpass) because D changes while the string sounds: bends, vibrato,
  slides and the tension-modulation glide move it continuously and across integers, and a FIR has
  no recursive state to carry a transient from one delay to the next.  When D leaves [1, 3) the
  termination moves one grid step along the string and D changes by 2, which leaves the loop's
  length, and the samples the Lagrange taps read, where they were (``kernel``).
* Loss: a one-pole low-pass H_loss(z) = g (1 + a) / (1 + a z^-1), -1 < a <= 0, fitted per loop
  length so that the loop decays as the finite-difference string does (``engine.fd.string``: the mode
  at frequency f decays at sigma(f) = sigma0 + sigma1 xi(f), xi the squared wavenumber, from the
  preset's two T60 values): |H_loss(f)| = exp(-sigma(f) P / fs) at the fundamental and at 2 kHz.
  |H_loss| <= g <= 1 at every frequency (passive).
* Dispersion: M identical first-order allpass sections A(z) = ((a + z^-1) / (1 + a z^-1))^M
  (Van Duyne & Smith 1994's cascade; the coefficient fitted numerically as in Rauhala & Valimaki
  2006), which delay low frequencies more than high ones, so the upper partials come out sharp as
  on a stiff string: f_n = n f1 sqrt(1 + B n^2) / sqrt(1 + B), B = pi^2 E I / (T L_s^2) for the
  speaking length L_s.  |A| = 1 (lossless).
* tau, the phase delay (samples) of the loss and dispersion filters at the fundamental, is what the
  tuning subtracts: 2 (N - n_t) + D + tau = fs / f (the fundamental exact to the Lagrange
  interpolator's phase error, which is of fourth order in the frequency: tests/engine/waveguide/
  test_tuning.py holds open strings to 1 cent and stopped ones to 3).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from .. import calibration_store
from ..losses import LN1000, loss_coefficients
from ..presets import Preset, StringSpec

MAX_SECTIONS = 4  # dispersion allpass sections at most
D_LOW, D_HIGH = 1.0, 3.0  # the fractional delay's range (samples)
DISPERSION_PARTIALS = 10  # partials 2..10 fitted (those below 0.4 fs)
SECTION_GAIN = 0.05  # cents^2 (summed over the partials) that an extra allpass section must save


@dataclass(frozen=True)
class Physical:
    """A preset string's physical constants (SI)."""

    length_m: float
    mu: float  # kg/m
    tension_n: float  # T = 4 L^2 mu f0^2 - pi^2 E I / L^2: the stiff string's tension at pitch
    ei: float
    ea: float
    f0: float

    @property
    def impedance(self) -> float:
        """Z = sqrt(T mu), kg/s: the wave impedance of one side of the string."""
        return math.sqrt(self.tension_n * self.mu)

    def inharmonicity(self, speaking_m: float, tension_ratio: float = 1.0) -> float:
        return math.pi**2 * self.ei / (self.tension_n * tension_ratio * speaking_m**2)


def physical(preset: Preset, string: int) -> Physical:
    spec: StringSpec = preset.strings[string - 1]
    length = preset.string_length_m(string)
    mu = spec.linear_density_kg_m
    f0 = spec.frequency_hz
    ei = spec.bending_stiffness_nm2
    tension = 4.0 * length**2 * mu * f0**2 - math.pi**2 * ei / length**2
    return Physical(length, mu, tension, ei, spec.youngs_modulus_pa * spec.area_m2, f0)


def decay_rate(spec: StringSpec, tension: float, f: float) -> float:
    """sigma(f), 1/s: the finite-difference string's decay rate of a mode at f Hz."""
    s0, s1 = loss_coefficients(spec, tension)
    mu = spec.linear_density_kg_m
    g2 = tension / mu
    k2 = spec.bending_stiffness_nm2 / mu
    w = 2.0 * math.pi * f
    xi = (-g2 + math.sqrt(g2 * g2 + 4.0 * k2 * w * w)) / (2.0 * k2) if k2 > 0 else w * w / g2
    return s0 + s1 * xi


def loss_filter(gain_f1: float, gain_f2: float, w1: float, w2: float) -> tuple[float, float]:
    """(g, a) of g (1 + a) / (1 + a z^-1) with |H(w1)| = gain_f1 and |H(w2)| = gain_f2 (w in
    rad/sample, w1 < w2, gains <= 1); a low-pass (a <= 0) with g <= 1, so |H| <= 1 everywhere."""
    r2 = min((gain_f2 / gain_f1) ** 2, 1.0)
    # (1 + 2 a cos w1 + a^2) = r2 (1 + 2 a cos w2 + a^2)  ->  (1 - r2) a^2 + 2 (c1 - r2 c2) a
    # + (1 - r2) = 0, the root inside the unit circle
    c1, c2 = math.cos(w1), math.cos(w2)
    qa, qb = 1.0 - r2, 2.0 * (c1 - r2 * c2)
    if qa < 1e-15:
        a = 0.0
    else:
        disc = max(qb * qb - 4.0 * qa * qa, 0.0)
        a = (-qb + math.sqrt(disc)) / (2.0 * qa)
        a = min(max(a, -0.999), 0.0)
    g = gain_f1 * math.sqrt(1.0 + 2.0 * a * c1 + a * a) / (1.0 + a)
    return min(g, 1.0), a


def allpass_delay(a: float, sections: int, w: float) -> float:
    """Phase delay of the dispersion cascade at one frequency (continuous in w from DC)."""
    if sections == 0 or a == 0.0:
        return float(sections)
    # the phase of one section is -w + 2 atan(a sin w / (1 + a cos w)); its delay is continuous
    one = 1.0 - 2.0 * math.atan2(a * math.sin(w), 1.0 + a * math.cos(w)) / w
    return sections * one


def loss_delay(g: float, a: float, w: float) -> float:
    """Phase delay of g (1 + a) / (1 + a z^-1) at w (samples)."""
    return -math.atan2(a * math.sin(w), 1.0 + a * math.cos(w)) / w


@lru_cache(maxsize=4096)
def dispersion_filter(inharmonicity: float, period: float, room: float) -> tuple[float, int]:
    """(a, sections) of the cascade that puts partials 2..10 of a loop of ``period`` samples at
    f_n = n f1 sqrt(1 + B n^2) / sqrt(1 + B), least squares in cents, with its delay at the
    fundamental at most ``room`` samples.  (0, 0) when the string is too flexible to need one or
    the loop too short to hold it.  The fit takes milliseconds and a song's strings ask it for
    every fret they stop: kept per process and on disk (``engine.calibration_store``, exact to
    the bit), so a song does not fit its frets again in every render."""
    if inharmonicity < 1e-7 or room < 2.0:
        return 0.0, 0
    a, sections = calibration_store.recall(
        "waveguide_dispersion", (inharmonicity, period, room),
        lambda: _fit_dispersion(inharmonicity, period, room), sources=("waveguide/string.py",))
    return float(a), int(sections)


def _fit_dispersion(inharmonicity: float, period: float, room: float) -> tuple[float, int]:
    """``dispersion_filter``'s least-squares fit."""
    w1 = 2.0 * math.pi / period
    n = np.arange(2, DISPERSION_PARTIALS + 1)
    target = n * w1 * np.sqrt(1.0 + inharmonicity * n * n) / math.sqrt(1.0 + inharmonicity)
    n = n[target < 0.4 * 2.0 * math.pi]
    target = target[: len(n)]
    if len(n) == 0:
        return 0.0, 0

    def partials(a: float, sections: int) -> np.ndarray:
        # loop: K + delay(w), K so that the fundamental is exact; partial n solves w (K + d(w)) = 2 pi n
        k = period - allpass_delay(a, sections, w1)
        w = target.copy()
        for _ in range(30):
            d = np.array([allpass_delay(a, sections, x) for x in w])
            w = 2.0 * math.pi * n / (k + d)
        return w

    from scipy.optimize import minimize_scalar  # here: its import is half a second

    best = (0.0, 0, math.inf)
    for sections in range(1, MAX_SECTIONS + 1):
        def err(a: float, sections: int = sections) -> float:
            if allpass_delay(a, sections, w1) > room:
                return 1e9
            w = partials(a, sections)
            return float(np.sum((1200.0 * np.log2(w / target)) ** 2))

        res = minimize_scalar(err, bounds=(-0.95, 0.0), method="bounded",
                              options={"xatol": 1e-5})
        # more sections cost a multiply-add chain per sample each: take one more only where it
        # brings the partials' squared error (cents^2, summed) down by more than SECTION_GAIN
        if res.fun < best[2] - SECTION_GAIN:
            best = (float(res.x), sections, float(res.fun))
    if best[1] == 0:
        return 0.0, 0
    return best[0], best[1]


@dataclass(frozen=True)
class Loop:
    """One termination's filters for a loop of ``period`` samples at its fundamental."""

    period: float  # fs / f of the note this configuration sounds (before bends)
    loss_g: float
    loss_a: float
    disp_a: float
    disp_m: int
    refl_g: float  # |reflection| of the termination (1 at the nut, the finger's g_f at a fret)
    tau: float  # phase delay of the loss and dispersion filters at the fundamental, samples
    gain_bound: float  # l1 norm of the termination's impulse response (a bound on its gain)


def design_loop(spec: StringSpec, phys: Physical, fs: float, f1: float, speaking_m: float,
                refl_g: float = 1.0, dispersion: bool = True) -> Loop:
    """The termination filters for a note of fundamental f1 Hz on a speaking length
    ``speaking_m``: loss fitted to the finite-difference string's decay at f1 and 2 kHz, dispersion
    to the stiff string's partials."""
    period = fs / f1
    w1 = 2.0 * math.pi * f1 / fs
    f2 = min(2000.0, 0.45 * fs)
    if f2 <= f1 * 1.05:
        f2 = min(0.45 * fs, 2.0 * f1)
    w2 = 2.0 * math.pi * f2 / fs
    # the loop takes `period` samples at every frequency to first order: the decay per trip
    sec = period / fs
    g1 = math.exp(-decay_rate(spec, phys.tension_n, f1) * sec)
    g2 = math.exp(-decay_rate(spec, phys.tension_n, f2) * sec)
    loss_g, loss_a = loss_filter(g1, min(g2, g1), w1, w2)
    room = period - 2.0 - D_HIGH - loss_delay(loss_g, loss_a, w1)
    disp_a, disp_m = (dispersion_filter(round(phys.inharmonicity(speaking_m), 12),
                                        round(period, 9), round(room, 6))
                      if dispersion else (0.0, 0))
    tau = loss_delay(loss_g, loss_a, w1) + (allpass_delay(disp_a, disp_m, w1) if disp_m else 0.0)
    ap_l1 = (1.0 + 2.0 * abs(disp_a)) ** disp_m
    lag_l1 = 1.25  # the largest sum |h_k| of the Lagrange taps for d in [1, 2]
    return Loop(period, loss_g, loss_a, disp_a, disp_m, refl_g, tau,
                refl_g * loss_g * ap_l1 * lag_l1)


def lagrange3(d: float) -> tuple[float, float, float, float]:
    """Taps of third-order Lagrange interpolation for a delay of d samples (best for d in [1, 2])."""
    return (-(d - 1.0) * (d - 2.0) * (d - 3.0) / 6.0, d * (d - 2.0) * (d - 3.0) / 2.0,
            -d * (d - 1.0) * (d - 3.0) / 2.0, d * (d - 1.0) * (d - 2.0) / 6.0)


def lagrange_delay(d: float, w: float) -> float:
    """Phase delay (samples) at w of the termination's Lagrange read for a delay d >= 1: taps
    ``lagrange3(x)`` on samples j0 .. j0 + 3 back, j0 = floor(d) - 1, x = d - j0 in [1, 2) (the
    kernel's ``_taps``); continuous from DC for w below pi / 2."""
    j0 = int(d) - 1
    h = lagrange3(d - j0)
    resp = sum(hk * complex(math.cos(w * k), -math.sin(w * k)) for k, hk in enumerate(h))
    return j0 - math.atan2(resp.imag, resp.real) / w


def loop_partials(loop: Loop, grid_delay: int, d: float, count: int) -> np.ndarray:
    """Frequencies (rad/sample) of partials 1..count of a linear loop: 2 (N - n_t) = ``grid_delay``
    samples on the rails, the Lagrange read of delay ``d`` and the loss and dispersion sections.
    The bridge's -1 and the termination's -1 make the loop's phase 2 pi n at partial n:
    w (grid_delay + lagrange_delay(d, w) + loss_delay(w) + allpass_delay(w)) = 2 pi n, solved by
    fixed-point iteration from the harmonic guess (the delays vary slowly with w)."""
    out = np.zeros(count)
    for i in range(count):
        n = i + 1
        w = 2.0 * math.pi * n / loop.period
        for _ in range(100):
            total = (grid_delay + lagrange_delay(d, w) + loss_delay(loop.loss_g, loop.loss_a, w)
                     + allpass_delay(loop.disp_a, loop.disp_m, w))
            w_next = 2.0 * math.pi * n / total
            if abs(w_next - w) < 1e-15 * w:
                break
            w = w_next
        out[i] = w_next
    return out


def grid_size(open_loop: Loop) -> int:
    """N: the open string's loop fills 2 N + D + tau samples with D in [1, 3)."""
    return max(int(math.floor((open_loop.period - open_loop.tau - D_LOW) / 2.0)), 2)


def decay_sigma_at(spec: StringSpec, phys: Physical, f: float) -> float:
    """The T60 (s) the loop is fitted to at f (for docs and tests)."""
    return LN1000 / decay_rate(spec, phys.tension_n, f)
