"""The plucking junction: a finger or plectrum as a time-varying mass-spring-damper (E&E sec. II).

The finger (mass M, stiffness K, damping R, force F0) moves with a string segment of mass mu X:

    (M + mu X) u_tt = -R u_t - K u + F(t) + F0(t)                                    (1)

E&E discretise (1) with centred differences on the waveguide's grid (X = c T), eq. (3), and turn
it into a junction that adds a perturbation h to the displacement arriving at n_p, half on each
rail (the balanced injection, eq. (12)): u_out+- = u_in+- + h / 2, i.e. the scattering matrix

    S = 1/2 [[H + 1, H - 1], [H - 1, H + 1]],   h = (H(z) - 1) u_in,                   (21)

whose eigenvectors are [1, 1] (eigenvalue H: the waves' common part, which the finger moves) and
[1, -1] (eigenvalue 1: the velocity integral w, which it leaves alone, eq. (15)).  Substituting
the waveguide into (3) gives them H = 1/A(z),

    c1 h(m+1) - c0 h(m) + (c_-1 - 1) h(m-1)
        = (1 - c1) u_in(m+1) + c0 u_in(m) + (1 - c_-1) u_in(m-1) + X F0(m) / K0       (16)
    A(z) = M' (1 - z^-1)^2 + rho (1 - z^-2) + kappa z^-1 + 1,                          (18)
    M' = M / (mu X),  rho = R / (2 sqrt(mu K0)),  kappa = K X / K0.                    (4), (5)

On this waveguide (16) gets two things wrong, both at low frequencies: its damper has A(1) = 1,
so a palm or a harmonic touch leaves the fundamental almost undamped (the palm-mute and harmonic
tests in tests/engine/waveguide fail with it); and its force term turns a force into a
displacement proportional to it, not a velocity, so a pluck comes out much weaker than the
finite-difference string's.  (3) and the waveguide are the same scheme only for states the
two rails can represent, which a point perturbation is not.  This model keeps E&E's junction (the
balanced perturbation, S of (21)) and takes H from the finger's continuous point impedance: a point
of mass M, stiffness K and damping R on a string of wave impedance Z = sqrt(T mu) on each side,
met by waves v_in+-, moves at v = (v_in+ + v_in-) / (1 + Gamma(s)), Gamma = (M s + R + K / s) / (2 Z):

    H(s) = (1 - Gamma(s)) / (1 + Gamma(s))

for velocity waves and so for displacement waves, their time integrals (S is linear), discretised
by the bilinear transform s = 2 fs (1 - z^-1) / (1 + z^-1).  With m' = M fs / Z, rho = R / (2 Z),
k' = K / (4 fs Z), Gamma(z) = N(z) / D(z),

    N = (m' + rho + k') + 2 (k' - m') z^-1 + (m' - rho + k') z^-2,   D = 1 - z^-2,
    h = -2 N / (D + N) u_in                                           (a biquad)

run on the increments of u_in and summed with a leak (``_msd``, ``LEAK_HZ``): at DC the junction
is the identity (a point cannot hold a static displacement on a string between fixed ends, and a
damper does not resist one), above a few tens of hertz it is the biquad.  For a damper,
H = 1 - g HP(z) with g = 2 rho / (1 + rho) and HP = (1 - z^-1) / (1 - leak z^-1), whose
Re HP = (1 + leak) / 2 |HP|^2, so |H| <= 1 iff g <= 1 + leak: ``max_damping`` caps rho there.
With a mass the leak costs a little passivity below LEAK_HZ (tests/engine/waveguide/
test_passivity.py bounds |H| by 1.03 with m' up to ``MAX_MASS_RATIO``, where contacts are capped:
a contact as heavy as ten grid steps of string already stops the point), for the milliseconds of
a pluck only.

A damper alone gives h = -2 rho / (1 + rho) u_in: a dashpot transmits 1 / (1 + rho) of a wave at
every frequency, as it should.  With M = K = R = 0, h = 0: S is the identity, and a slot costs
nothing outside its event (the kernel visits it only while it acts).

Passivity.  The two eigenvectors of S are orthogonal, so S is contractive in the waves' energy (the
sum over both rails of mu X (du/dt)^2, d'Alembert's kinetic plus potential energy) iff
|H(e^jw)| <= 1, i.e. Re Gamma(e^jw) >= 0.  Gamma(s) is positive real for M, R, K >= 0 (a passive
mechanical impedance) and the bilinear transform maps positive-real functions to discrete
positive-real ones, so every junction here is passive for all non-negative parameters at any
sample rate (unlike (16): the paper's eq. (23) warns that |1/A| can exceed 1 and relies on the
pluck's short duration).  The parameters ramp with the pulse's envelope and the filter's state is
carried between steps, which is not energy-neutral in general; the junction acts for a finite time
and leaves the identity behind (the paper's BIBO argument, eqs. (24)-(25)), and the soak test
checks that no scene grows.  A junction whose point the termination has cut off the sounding
string (the termination walks towards the bridge when the pitch rises: a glide, a bend, a
stop) does not act, and when its point is back it starts afresh, as at its onset (state zero,
its input taken from there: ``J_CUT``): its perturbation h and its last input belonged to
the part of the string that was cut off and is gone.  Resuming with them would add that old h
to the rails at every step until the leak forgot it, a source and not a junction (a random
scene whose glide swept the termination over two junctions gained thirty times its energy;
``test_a_junction_cut_off_by_the_termination_starts_afresh``).

The force.  A point force F moves an ideal string at F / (2 Z): a velocity.  It enters as the
paper's velocity blow (eq. (38), ``_blow``): a plateau of height F T / (2 Z) per sample spreading
from the point, the finite-difference model's excitation on the same string.  (The whole force
drives the string, the finite-difference model's convention; the finger's impedance acts on the
waves that pass it during the pulse.)

Force shapes and phases.  F0(t) is the scene's pluck pulse, the finite-difference model's f_e(t):
F0 = F sin^2(pi t / (2 Delta)) for 0 <= t <= Delta, then released at once (the detach phase);
``style`` sets Delta and the sign (``engine.performance.PLUCK_STYLES``: pick 0.3 ms, finger 1 ms,
slap 0.5 ms towards the fretboard, pop 2 ms away from it).  M(t), K(t) and R(t) follow the same
envelope (the contact builds up with the force) and then let go over the pulse's length (an
abrupt end would drop the junction's perturbation h at once: a displacement step, i.e. a click;
steady contacts, the palm and the touches, let go over 2 ms the same way), scaled by ``STYLES``: a
fingertip is a heavier, lossier contact than a plectrum.  The spring K of (1) is kept at zero in
every style: it holds a static displacement against the player's force, and the scene's force is
already the force on the string; with a spring to the finger's rest the pulse and the spring
fight, and the spring snaps the string back at release (a click several times the pluck's own
peak).  The junction still takes one.  The contact is spread over the
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
MAX_MASS_RATIO = 10.0  # m' cap
LEAK_HZ = 20.0  # the junction's sum of increments forgets with this corner frequency
J_STATE = 7  # a junction point's state: ``_msd``'s six values and J_CUT
J_CUT = 6  # 1 while the termination has cut the point off the sounding string (``kernel``)


@dataclass(frozen=True)
class Contact:
    """A finger's or pick's contact with the string at the peak of a pluck (the ADSR maxima)."""

    mass_kg: float
    stiffness_n_m: float
    damping_n_s_m: float
    width_m: float
    window: str  # "bell" or "triangle"


STYLES = {
    # fingertip flesh: a little mass and damping; ~1 cm of string in contact
    "finger": Contact(2e-5, 0.0, 0.05, 0.010, "bell"),
    # plectrum: light, a narrow edge
    "pick": Contact(5e-6, 0.0, 0.01, 0.002, "triangle"),
    # knuckle or thumb side: heavier and lossier
    "slap": Contact(5e-5, 0.0, 0.1, 0.012, "bell"),
    # a finger hooked under the string
    "pop": Contact(2e-5, 0.0, 0.05, 0.008, "bell"),
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


def max_damping(rate: float) -> float:
    """The largest rho a damper may have and stay passive with the leak: g = 2 rho / (1 + rho)
    <= 1 + leak (``LEAK_HZ``), just below (1 + leak) / (1 - leak) (about 700 at 44.1 kHz: far
    above any contact, where the point is all but clamped)."""
    leak = math.exp(-2.0 * math.pi * LEAK_HZ / rate)
    return 0.999 * (1.0 + leak) / (1.0 - leak)


@njit(**JIT_INLINE)
def _msd(uin, jst, j, k, mp, rho, kp, leak):
    """One step of the junction at one point; returns h.  The biquad g = -2 N / (D + N) runs on
    the increments of the arriving displacement ``uin`` and h is their leaky sum,
    h(m) = leak h(m-1) + g(m): the junction scatters the motion (the velocity waves, integrated)
    and never holds a static displacement, which a string between fixed ends cannot keep and a
    damper does not resist (acting on the displacement itself, a steady damper pinned the point
    to where it was and the string's energy crept up).  State jst[j, k] = [h(m-1), g(m-1),
    g(m-2), du(m-1), du(m-2), u_in(m-1)] (updated); m', rho, k' as above."""
    du = uin - jst[j, k, 5]
    jst[j, k, 5] = uin
    if mp == 0.0 and kp == 0.0:  # a damper: g = -2 rho / (1 + rho) du (the biquad would carry
        # the same through a pole-zero pair on the unit circle, z = +-1)
        g = -2.0 * rho / (1.0 + rho) * du
    else:
        a0 = mp + rho + kp
        a1 = 2.0 * (kp - mp)
        a2 = mp - rho + kp
        g = (-2.0 * (a0 * du + a1 * jst[j, k, 3] + a2 * jst[j, k, 4]) - a1 * jst[j, k, 1]
             - (a2 - 1.0) * jst[j, k, 2]) / (1.0 + a0)
    jst[j, k, 2] = jst[j, k, 1]
    jst[j, k, 1] = g
    jst[j, k, 4] = jst[j, k, 3]
    jst[j, k, 3] = du
    h = leak * jst[j, k, 0] + g
    jst[j, k, 0] = h
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
