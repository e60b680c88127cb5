"""The plucking junction: a finger or plectrum as a time-varying mass-spring-damper (E&E sec. II).

The finger (mass M, stiffness K, damping R, force F0) moves with a string segment of mass mu X:

    (M + mu X) u_tt = -R u_t - K u + F(t) + F0(t)                                    (1)

discretised with centred differences on the waveguide's grid (X = c T) this is

    c1 u(n_p, m+1) - c0 u(n_p, m) + c_-1 u(n_p, m-1) = u(n_p+1, m) + u(n_p-1, m) + X F0(m) / K0   (3)
    c1 = 1 + M' + rho,  c0 = 2 M' - kappa,  c_-1 = 1 + M' - rho,
    M' = M / (mu X),  rho = R / (2 sqrt(mu K0)),  kappa = K X / K0.                  (4), (5)

The junction adds a perturbation h to the displacement arriving at n_p, half on each rail (the
balanced injection, eq. (12)): u_out+- = u_in+- + h / 2, and with u_in = u_in+ + u_in- eq. (3)
becomes the recursion that the kernel runs (``_msd``):

    c1 h(m+1) - c0 h(m) + (c_-1 - 1) h(m-1)
        = (1 - c1) u_in(m+1) + c0 u_in(m) + (1 - c_-1) u_in(m-1) + X F0(m) / K0       (16)

i.e. the scattering matrix S = 1/2 [[1/A + 1, 1/A - 1], [1/A - 1, 1/A + 1]] of eq. (21) with
A(z) = M' (1 - z^-1)^2 + rho (1 - z^-2) + kappa z^-1 + 1 (eq. (18)).  With M = K = R = F0 = 0,
A = 1, h = 0: S is the identity and the junction costs nothing; a slot is only visited while its
event acts.

Passivity.  The paper notes (eq. (23)) that |1/A| can exceed 1, so S is not contractive in the
waves' own norm; what bounds the string is the energy of the equivalent finite-difference scheme.
A waveguide at X = c T *is* the centred scheme for u_tt = c^2 u_xx at Courant number 1, and (3) is
that scheme with the lumped mass, spring and damper at n_p.  Its energy (per grid step, T = 1)

    H = sum_n mu X / 2 (u_n^m - u_n^{m-1})^2 + K0 / (2 X) sum_n (u_{n+1}^m - u_n^m)(u_{n+1}^{m-1} - u_n^{m-1})
        + M / 2 (u_p^m - u_p^{m-1})^2 + K / 2 u_p^m u_p^{m-1}

obeys H^{m+1/2} - H^{m-1/2} = -R (u_p^{m+1} - u_p^{m-1})^2 / 4 + F0 (u_p^{m+1} - u_p^{m-1}) / 2, and
is non-negative when the string's part is (Courant number 1: it is, marginally) and the finger's is:
K / 2 u^m u^{m-1} = K / 8 [(u^m + u^{m-1})^2 - (u^m - u^{m-1})^2], so M / 2 >= K / 8 (per step),
i.e. K T^2 <= 4 M, the finger's own oscillator resolved at the sample rate.  ``controls`` clips K
to that bound (a massless contact gets no spring) and R, M >= 0, so with F0 = 0 the junction only
dissipates.  The parameters vary in time (they ramp with the force pulse); a change of M or K
between steps is not energy-neutral, but the junction acts for a finite time and leaves the
identity behind (the paper's BIBO argument, eqs. (24)-(25)), and the soak test checks that no
scene grows.

Force shapes and phases.  F0(t) is the scene's pluck pulse, the finite-difference model's f_e(t):
F0 = F sin^2(pi t / (2 Delta)) for 0 <= t <= Delta, then released at once (the detach phase);
``style`` sets Delta and the sign (``engine.controls.PLUCK_STYLES``: pick 0.3 ms, finger 1 ms,
slap 0.5 ms towards the fretboard, pop 2 ms away from it).  M(t), K(t) and R(t) follow the same
envelope (the contact builds up with the force and ends at release), scaled by ``STYLES``: a
fingertip is a heavier, softer, lossier contact than a plectrum.  The contact is spread over the
string with a tapering window (the paper's "tapered plucking zone for thick strings"): a bell
(Hann) window ``width_m`` wide for a finger, a triangle for a pick, over as many grid points as it
covers (X is 2.4 mm on the E2 string and 9.7 mm on E4 at 44.1 kHz), at most ``MAX_POINTS``.

The same junction with other parameters is the light fingering junction of E&E sec. IV-B (a
finger resting on the string without stopping it: a dead note), the harmonics junction (a light
touch) and the palm mute (``controls``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from numba import njit

from ..config import JIT_INLINE

MAX_POINTS = 5


@dataclass(frozen=True)
class Contact:
    """A finger's or pick's contact with the string at the peak of a pluck (the ADSR maxima)."""

    mass_kg: float
    stiffness_n_m: float
    damping_n_s_m: float
    width_m: float
    window: str  # "bell" or "triangle"


STYLES = {
    # fingertip flesh: a little mass and damping, soft; ~1 cm of string in contact
    "finger": Contact(5e-5, 2.0e3, 0.05, 0.010, "bell"),
    # plectrum: light and stiff, a narrow edge
    "pick": Contact(1e-5, 2.0e4, 0.01, 0.002, "triangle"),
    # knuckle or thumb side: heavier
    "slap": Contact(1e-4, 5.0e3, 0.05, 0.012, "bell"),
    # a finger hooked under the string
    "pop": Contact(5e-5, 5.0e3, 0.05, 0.008, "bell"),
}


def window(kind: str, width_m: float, x_m: float, grid_x: float, n_of) -> list[tuple[int, float]]:
    """(grid index, weight) pairs, weights summing to 1, of a contact ``width_m`` wide centred at
    ``x_m`` metres from the nut; ``n_of(x)`` is the fractional grid index of x, ``grid_x`` metres
    per grid step.  A contact narrower than a step is split between the two nearest points."""
    centre = n_of(x_m)
    half = 0.5 * width_m / grid_x
    if half <= 1.0:
        i = int(math.floor(centre))
        w1 = centre - i
        pts = [(i, 1.0 - w1), (i + 1, w1)]
    else:
        half = min(half, 0.5 * (MAX_POINTS + 1))
        lo, hi = int(math.ceil(centre - half)), int(math.floor(centre + half))
        pts = []
        for i in range(lo, hi + 1):
            r = abs(i - centre) / half
            w = 0.5 * (1.0 + math.cos(math.pi * r)) if kind == "bell" else max(1.0 - r, 0.0)
            pts.append((i, w))
        pts = sorted(pts, key=lambda p: -p[1])[:MAX_POINTS]
    total = sum(w for _, w in pts)
    merged: dict[int, float] = {}
    for i, w in pts:
        if w > 0.0:
            merged[i] = merged.get(i, 0.0) + w / total
    return sorted(merged.items())


@njit(**JIT_INLINE)
def _msd(uin, st, f_prev, mp, rho, kappa, x_k0):
    """One step of eq. (16) at one point: the perturbation h(m+1) from the arriving displacement
    ``uin`` = u_in(m+1), the point's state st = [h(m), h(m-1), u_in(m), u_in(m-1)] (updated), the
    force F0(m) of the step before, and the dimensionless M', rho, kappa and X / K0."""
    c1 = 1.0 + mp + rho
    c0 = 2.0 * mp - kappa
    cm1 = 1.0 + mp - rho
    h = (c0 * st[0] - (cm1 - 1.0) * st[1] + (1.0 - c1) * uin + c0 * st[2]
         + (1.0 - cm1) * st[3] + x_k0 * f_prev) / c1
    st[1] = st[0]
    st[0] = h
    st[3] = st[2]
    st[2] = uin
    return h


@njit(**JIT_INLINE)
def _envelope(t, length):
    """The pluck pulse's shape at step t of ``length`` (sin^2 rise, then release); 1 for a steady
    contact (length 0)."""
    if length <= 0:
        return 1.0
    if t < 0 or t > length:
        return 0.0
    s = math.sin(0.5 * math.pi * t / length)
    return s * s
