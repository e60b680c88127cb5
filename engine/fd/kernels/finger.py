"""The finger of eqs. (9)-(10): a mass w pressed towards the fretboard by an external force, in
contact with the string through a damped Hertzian spring, K (eta)_+^(alpha + 1) / (alpha + 1) with
eta = j^T u - w the string's reach past the fingertip, eqs. (25)-(27); its own update, eq. (39), and
its scalar auxiliary variable, eqs. (39)-(41) and (55c-d).  Here are the finger's terms; its column
of the small system is assembled in the step loops (``step._advance``, ``runs._held_run``), which
call these helpers so that both work out the same numbers.
"""

from __future__ import annotations

import math

from numba import njit

from ...config import JIT_HELPER
from .data import EPS


@njit(**JIT_HELPER)
def _finger_x(x0, x1, ms, me, step):
    """The finger's place along the string (m) at a step: x0 until step ms, gliding linearly to
    x1 at step me (a slide), or moving at once at ms if me <= ms."""
    if me <= ms:
        return x0 if step < ms else x1
    if step <= ms:
        return x0
    if step >= me:
        return x1
    return x0 + (x1 - x0) * (step - ms) / (me - ms)


@njit(**JIT_HELPER)
def _eta(w0, w1, p, U, w):
    """eta = j^T u - w: how far the string at the finger's interpolant (node p, weights w0, w1)
    is past the fingertip at w (> 0: in contact)."""
    return w0 * U[p] + w1 * U[p + 1] - w


@njit(**JIT_HELPER)
def _w_free(w, w1, lam_f, fext):
    """The finger's position at n + 1 under its external force alone, eq. (39): w_free =
    2 w^n - w^(n-1) + (k^2 / M) f_ext."""
    return 2.0 * w - w1 + lam_f * fext


@njit(**JIT_HELPER)
def _beta(c, eta):
    """beta~ of the finger's SAV in contact (eta > 0), eq. (55c): V'(eta) / sqrt(2 V(eta) + eps)
    for V = K eta^(alpha + 1) / (alpha + 1), with the gauge epsilon of eq. (54)."""
    ea = eta if c.fg_alpha == 1.0 else eta**c.fg_alpha  # pow() is slow
    vpot = c.fg_k / (c.fg_alpha + 1.0) * ea * eta
    return c.fg_k * ea / math.sqrt(2.0 * vpot + EPS)


@njit(**JIT_HELPER)
def _finger_row(bt, psi_f, eta1, chi, rdamp):
    """The finger's row of the small system, x + c eta^(n+1) = -a, from its force
    x = -bt (psi_f + bt (eta^(n+1) - eta^(n-1)) / 4) - chi R (eta^(n+1) - eta^(n-1)) / (2 k)
    (eqs. (55c-d) with the contact damping, ``rdamp`` = R / (2 k), acting while chi = 1):
    returns (c, a)."""
    cf = 0.25 * bt * bt + chi * rdamp
    return cf, bt * psi_f - cf * eta1
