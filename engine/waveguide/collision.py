"""Collision junctions along the neck: the string against the frets and the fretboard (E&E sec. III).

Each grid point under the neck carries the height u_ref < 0 of the obstacle below it (a fret's
crown where a fret is, else the fretboard, a fret height lower), measured from the string's
current rest line (straight from nut to bridge, or from the crown of the stopping fret to the
bridge: E&E sec. IV-B's "linear scaling" of the action profile).  A collision happened in the
last sample interval when

    u_in(m) <= u_ref < 0                                                              (26)

and the junction then fixes the displacement on the obstacle by a balanced perturbation,

    h(m) = u_ref - u_in(m),   u_out+- = u_in+- + h / 2,                               (27)-(28)

the scattering matrix S_c = 1/2 [[1, -1], [-1, 1]] of eq. (29) plus u_ref / 2 on each rail: the
point stops on the obstacle while both sides of it stay connected (no split string, no jump when
it leaves, eqs. (32)-(36)).  Semi-elastic collisions (sec. III-C) get the approximate restitution
push of the paper: only while the point arrives (v_in < 0), u_ofs = -C_R v_in dT with dT = T / 2
(the mean of the unknown collision time), added after the test:

    h(m) = u_ref - u_in(m) + u_ofs                                                    (39)

C_R is ``FRET_RESTITUTION`` on the metal fret crowns (bright rattle) and ``BOARD_RESTITUTION`` on
the wooden fretboard (close to inelastic), as sec. IV-C advises.

Passivity.  h only moves the point towards its rest line (h > 0 against an obstacle below), and
only when the point is at or past the obstacle: in the equivalent finite-difference scheme the
junction replaces u_p^{m+1} by a value closer to the obstacle than where the free update put it,
i.e. it is an infinitely heavy, perfectly inelastic partner taking the point's momentum (kinetic
energy lost, eq. (32): u_out = u_ref).  The restitution push returns at most C_R <= 1 of the
arrival speed over half a step, so the point leaves no faster than it came; a point the
termination has cut off the sounding string forgets its previous displacement (``NO_PREV``), so
that on its return its arrival speed is not taken from another part of the string's motion.
Tested by the soak.

Where the junctions are active.  Checking every neck point in every sample would cost what the
waveguide saves.  Every ``REACH_EVERY`` samples the kernel bounds, for each candidate point, how
far the string can move there before the next check: a displacement at n within B samples is the
sum of a right-going wave now within B points to its left and a left-going one within B points to
its right (eq. (7)), so |u(n, m + j)| <= max |u+| over [n - B, n] + max |u-| over [n, n + B],
taken over segments of B points; where that window reaches a termination the reflected waves are
bounded by the rails' largest value times the termination's gain bound (the l1 norm of its
impulse response).  That bound is loose near a fixed end, where the two waves are large and
cancel, which is where a stopped string's next frets are.  So a second one bounds the displacement
by the energy, which the passive string cannot gain: u(x) = integral of u_x from either end, so
|u(x)|^2 <= x (L - x) / L * integral u_x^2 dx (Cauchy-Schwarz on both sides), and
T / 2 * integral u_x^2 <= E = T * integral (u+_x^2 + u-_x^2) dx, the rails' energy, so
|u(x)|^2 <= 2 x (L - x) / L * sum (du+-)^2 over the grid (x, L in grid steps from the
termination), times ``ENERGY_SAFETY`` for the energy in transit inside the termination's filters.
It holds while nothing drives the string: a junction with a force, a mass or a spring (a pluck,
a tap's contact) anywhere on it switches it off, and within B points of a candidate makes the
candidate checked for the whole stretch.  A plain damper (a damp, a palm, a harmonic touch, a light
finger) only takes energy, and what its leaky sum holds comes back as a released junction's leak
does, for which the energy bound is already relied on: beside a damper in contact the candidates
take the energy bound alone (the segments' maxima assume waves that pass freely, which a damper's
reflection breaks), so a damped string tests only the points its energy can still reach.  While
that bound holds, the points it leaves out cannot reach their obstacles before the next bound, so
no collision is missed and the samples are those of every point tested (measured so, to the bit:
``tools.wg_skips``, tests/engine/waveguide/test_skips.py;
``WaveguideOptions.damper_bound=False`` tests them all: on songs, where a note ends with the hand
resting on the string until the next one, that was most of the waveguide's time).  Only the
points whose bound reaches their obstacle are tested, sample by sample; the rest cost nothing
until the next bound.  A quiet
string (no junction acting until the next ``kernel.BLOCK`` step, a steady pitch, and the energy
bound at least ``kernel.QUIET_MARGIN`` times below every obstacle) needs no bound before that
step: its energy does not grow while nothing acts on it, so the energy bound holds for all that
time, with the margin for what the termination's filters hold beyond ``ENERGY_SAFETY``.
"""

from __future__ import annotations

import math

from numba import njit

from ..config import JIT_INLINE

FRET_RESTITUTION = 0.5
BOARD_RESTITUTION = 0.05
REACH_EVERY = 256  # samples between two bounds (B), and the segment length of the bound
# a point's previous displacement when it has none (cut off the sounding string by the
# termination): its arrival speed is +inf, so it gets no restitution push (``_collide``)
NO_PREV = -math.inf


@njit(**JIT_INLINE)
def _collide(R, Mb, mask, s, n, ref, cr, prev, fs):
    """Eqs. (26)-(28) and (39) at grid point n at step s; returns the point's displacement after
    the step (the next step's previous displacement, for v_in)."""
    ip = (s - n) & mask
    im = (s + n) & mask
    uin = R[ip] + Mb[im]
    if uin > ref:
        return uin
    h = ref - uin
    vin = (uin - prev) * fs
    if vin < 0.0:
        h -= cr * vin * 0.5 / fs
    R[ip] += 0.5 * h
    Mb[im] += 0.5 * h
    return uin + h
