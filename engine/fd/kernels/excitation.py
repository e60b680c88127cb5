"""The excitation: the raised-sine pluck force f_e of eq. (5), spread onto the string by its
interpolant, eqs. (4) and (19).
"""

from __future__ import annotations

import math

from numba import njit

from ...config import JIT_HELPER
from .linear import _q_index


@njit(**JIT_HELPER)
def _pluck_force(step, e, pl_start, pl_len, pl_amp):
    """(acting, f): whether pluck e acts at this step, and its raised-sine force, eq. (5)."""
    m = step - pl_start[e]
    if m < 0 or m > pl_len[e]:
        return False, 0.0
    s_ = math.sin(0.5 * math.pi * m / pl_len[e])
    return True, pl_amp[e] * s_ * s_


@njit(**JIT_HELPER)
def _pluck_forces(c, step, UF, Q, quf, pl_start, pl_len, pl_amp, pl_p, pl_w0, pl_w1):
    """b) The plucks' forces f_e^n of eq. (5) added to u_free through their interpolants, eq. (19);
    returns q.u_free kept current (with Kirchhoff-Carrier)."""
    lam = c.lam
    for e in range(pl_start.shape[0]):
        acting, f = _pluck_force(step, e, pl_start, pl_len, pl_amp)
        if acting:
            p_ = pl_p[e]
            UF[p_] += lam * pl_w0[e] * f
            UF[p_ + 1] += lam * pl_w1[e] * f
            if c.kc > 0.0:
                quf += lam * f * (pl_w0[e] * Q[_q_index(p_)] + pl_w1[e] * Q[_q_index(p_ + 1)])
    return quf
