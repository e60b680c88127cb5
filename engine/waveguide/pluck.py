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

Passivity.  S has the eigenvectors [1, 1] (eigenvalue 1/A) and [1, -1] (eigenvalue 1), which
are orthogonal, so at each frequency the junction is contractive in the waves' energy (the sum
over both rails of mu X (du/dt)^2, d'Alembert's kinetic plus potential energy) iff
|A(e^jw)| >= 1.  With s = sin^2(w / 2),

    |A|^2 = (1 + kappa - (2 + 4 M') s)^2 + 4 (1 + 2 rho)^2 s (1 - s),

and |A|^2 - 1 is a quadratic in s that is >= 0 on [0, 1] when its linear coefficient and its
value at s = 1 are: (1 + 2 rho)^2 >= (1 + kappa)(1 + 2 M') and kappa <= 4 M' (the finger's
oscillator resolved at the sample rate, K T^2 <= 4 M).  A mass without damping fails the first
(|1/A| ~ 1 + M' w^2 > 1 at low frequencies: the paper's eq. (23) warning), which the paper accepts
for a pluck because it lasts milliseconds.  Here every junction is made passive at every value
of its envelope e in [0, 1] (all three parameters scale with e): kappa <= 4 M' and
rho >= max((kappa + 2 M') / 4, sqrt(kappa M' / 2)) are sufficient, and ``passive`` raises rho to
that bound where a contact's own damping is less (a heavy finger resting on the string is then
the heavily damped contact it is in life; in the limit it is the collision matrix S_c of eq. (29),
norm 1).  The force is not part of (16) here: the scene's force is a force on the string, whose
effect is a velocity (a point force F moves an ideal string at F / (2 Z)), and the balanced
displacement injection of (16) would turn it into a displacement proportional to F.  It enters as
the paper's velocity blow (eq. (38), ``_blow``) instead, a plateau of height F T / (2 Z) per
sample, which is the finite-difference model's excitation on the same string.

Force shapes and phases.  F0(t) is the scene's pluck pulse, the finite-difference model's f_e(t):
F0 = F sin^2(pi t / (2 Delta)) for 0 <= t <= Delta, then released at once (the detach phase);
``style`` sets Delta and the sign (``engine.controls.PLUCK_STYLES``: pick 0.3 ms, finger 1 ms,
slap 0.5 ms towards the fretboard, pop 2 ms away from it).  M(t), K(t) and R(t) follow the same
envelope (the contact builds up with the force and ends at release), scaled by ``STYLES``: a
fingertip is a heavier, softer, lossier contact than a plectrum (``passive`` then sets the
damping each needs).  The contact is spread over the
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


def passive(mp: float, rho: float, kappa: float) -> tuple[float, float, float]:
    """(M', rho, kappa) with kappa clipped to 4 M' and rho raised to the bound above, so that the
    junction is passive at every envelope value."""
    kappa = min(kappa, 4.0 * mp)
    rho = max(rho, 0.25 * (kappa + 2.0 * mp), math.sqrt(0.5 * kappa * mp))
    return mp, rho, kappa


@njit(**JIT_INLINE)
def _msd(uin, st, mp, rho, kappa):
    """One step of eq. (16) at one point, without its force term (the force is a velocity blow,
    ``_blow``): the perturbation h(m+1) from the arriving displacement ``uin`` = u_in(m+1), the
    point's state st = [h(m), h(m-1), u_in(m), u_in(m-1)] (updated) and the dimensionless M',
    rho, kappa."""
    c1 = 1.0 + mp + rho
    c0 = 2.0 * mp - kappa
    cm1 = 1.0 + mp - rho
    h = (c0 * st[0] - (cm1 - 1.0) * st[1] + (1.0 - c1) * uin + c0 * st[2]
         + (1.0 - cm1) * st[3]) / c1
    st[1] = st[0]
    st[0] = h
    st[3] = st[2]
    st[2] = uin
    return h


@njit(**JIT_INLINE)
def _blow(R, Mb, mask, s, n, N, c):
    """A velocity blow at grid point n (E&E eq. (38)): -c on u+ and +c on u- at every point from n
    to the bridge.  The displacement is unchanged now; from the next sample a plateau of height c
    spreads from the point, i.e. the point moved c in one sample.  A force F acting for one
    sample moves a point of an ideal string (two sides of impedance Z) by F T / (2 Z): c =
    F X / (2 K0).  The step keeps u(N) = 0 at the bridge and changes the velocity integral w only
    to the right of n, as (38) requires."""
    for i in range(n, N + 1):
        R[(s - i) & mask] -= c
        Mb[(s + i) & mask] += c


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
