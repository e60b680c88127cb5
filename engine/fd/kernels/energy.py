"""The discrete energy of eqs. (42)-(46): the stored energy H^(n+1/2), the losses Q and the supplied
power P of each step, booked when diagnostics are asked for, so that the relative energy-balance
deviation of sec. 6.1 can be reported.
"""

from __future__ import annotations

from numba import njit

from ...config import JIT, JIT_HELPER
from .data import ACTIVE
from .excitation import _pluck_force


@njit(**JIT_HELPER)
def _step_energy(c, ratio, step, step0, it, UF, U0, U1, psi, f_state, f_psi, f_w, f_w1, pl_start,
                 pl_len, pl_amp, pl_p, pl_w0, pl_w1, pin, inject, qloss, tens, e_h, e_q, e_p):
    """Diagnostics of step ``it``: e_h = H^(n+1/2), e_q = k Q^n (``qloss``: the losses the step
    booked, finger damping and rigid reactions) and e_p = k P^n (``pin``: the work the fingers'
    forces did, ``inject``: the energy a finger brought or took away), plus the plucks' work and
    that of a changing tension, both added here."""
    for e in range(pl_start.shape[0]):
        acting, f = _pluck_force(step, e, pl_start, pl_len, pl_amp)
        if acting:
            p_ = pl_p[e]
            dv = pl_w0[e] * (UF[p_] - U1[p_]) + pl_w1[e] * (UF[p_ + 1] - U1[p_ + 1])
            pin += f * dv * 0.5
    h_, ql, w_half = _energy(c, c.t0 * ratio, UF, U0, U1, psi, f_state, f_psi, f_w, f_w1)
    # a tension that changes from T^(n-1) to T^n does work (T^n - T^(n-1)) W^(n-1/2) on the
    # string, where V_L = T^n W^(n+1/2) + ... (see _energy)
    if it == 0 and step0 == 0:
        tens[0] = c.t0 * ratio
    ptens = (c.t0 * ratio - tens[0]) * tens[1]
    tens[0] = c.t0 * ratio
    tens[1] = w_half
    e_h[it] = h_
    e_q[it] = ql + qloss
    e_p[it] = pin + inject + ptens


@njit(**JIT)
def _energy(c, tension, UN, U0, U1, psi, f_state, f_psi, f_w, f_w1):
    """H^(n+1/2) of eqs. (43)-(45), k Q^n of eq. (46a) (string and fingers), and
    W^(n+1/2) = -(h/2) u^(n+1)^T D u^n, so that V_L = T^n W^(n+1/2) + (h/2) E I (D u^n).(D u^(n+1))."""
    n = c.n
    k = c.k
    ih2 = c.ih2
    kin = 0.0
    kin_d = 0.0
    vt = 0.0
    vs = 0.0
    kcd = 0.0
    lo0 = 0.0
    lo1 = 0.0
    for j in range(n):  # intervals between nodes j and j+1 (padded j+1, j+2)
        dn = UN[j + 2] - UN[j + 1]
        d0 = U0[j + 2] - U0[j + 1]
        vt += dn * d0
        a = (UN[j + 2] - U0[j + 2]) - (UN[j + 1] - U0[j + 1])
        kin_d += a * a
        b = (UN[j + 2] - U1[j + 2]) - (UN[j + 1] - U1[j + 1])
        lo1 += b * b
    for j in range(n - 1):
        p = j + 2
        a = UN[p] - U0[p]
        kin += a * a
        lapn = (UN[p - 1] - 2.0 * UN[p] + UN[p + 1]) * ih2
        lap0 = (U0[p - 1] - 2.0 * U0[p] + U0[p + 1]) * ih2
        vs += lapn * lap0
        kcd += UN[p] * lap0
        b = UN[p] - U1[p]
        lo0 += b * b
    h = c.h
    tl = 0.5 * c.rho_a_h / (k * k) * (kin - c.sigma1 * k * ih2 * kin_d)
    w_half = 0.5 * h * vt * ih2
    vl = tension * w_half + 0.5 * h * c.ei * vs
    vkc = 0.5 * c.kc * kcd * kcd
    hh = tl + vl + vkc + 0.5 * psi[0] * psi[0] + 0.5 * psi[1] * psi[1]
    for s in range(f_state.shape[0]):
        if f_state[s] == ACTIVE:
            v = (f_w[s] - f_w1[s]) / k
            hh += 0.5 * c.fg_mass * v * v + 0.5 * f_psi[s] * f_psi[s]
    q = 2.0 * c.rho_a_h * (c.sigma0 * lo0 + c.sigma1 * ih2 * lo1) / (4.0 * k * k) * k
    return hh, q, w_half
