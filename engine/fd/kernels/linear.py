"""The string: the stiff, lossy linear update of the DAFx24 scheme, eqs. (36) and (50a-c), fused with
the Kirchhoff-Carrier column q = D u^n and its dot products, eqs. (37) and (52); the stencil under a
bend's tension; the interpolant j of eqs. (15)-(16) through which point forces act and points are
read (1^T j = 1); the pickups' read-out of the string's velocity.

Arrays ``U`` hold the N - 1 interior nodes with two ghost cells each side (see ``engine.fd.kernels``);
loops run over non-negative offsets (U[j] ... U[j + 4]) so that LLVM vectorises them.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ...config import JIT, JIT_HELPER


@njit(**JIT_HELPER)
def interp(x: float, h: float, n: int):
    """Linear interpolant j^(x) (eq. (15)-(16)): padded index of the left node and two weights.

    Weights on the fixed end nodes are dropped (those nodes never move), so 1^T j = 1 holds except
    within one grid step of an end.
    """
    s = x / h
    l = int(math.floor(s))
    if l < 0:
        l = 0
    if l > n - 1:
        l = n - 1
    a = s - l
    w0 = 1.0 - a
    w1 = a
    if l == 0:
        w0 = 0.0
    if l + 1 == n:
        w1 = 0.0
    return l + 1, w0, w1


# The linear pass, a) of the step, is one compiled kernel, not inlined (with fastmath, so that LLVM
# vectorises its float sums: S and the Kirchhoff-Carrier dot products), that the quiet run, the
# held run and the general path each call themselves (a helper around the call counted the
# references of the arrays it passed in every step: ``config.JIT_HELPER``).  The three loops
# therefore get the same sums to the last bit by construction; inlined into each loop, they would
# rely on LLVM vectorising every copy the same way, which it does not guarantee.  The call costs
# each step a few ns.
# The kernels take the coefficients they use, not ``Coefs``: every field passed is an argument to
# marshal in each call.
@njit(**JIT)
def _pass_kc(n, b0, b1, b2, c0, c1, ih2, U0, U1, UF, Q, board, near, count):
    """a) + KC: u_free, q = D u^n, q.q, q.u_free, q.u^(n-1), S = sum of (u_(i+1) - u_i)^2 over
    the N intervals of u^n, and the nodes of u^n below the fretboard and within reach of a fret
    tip (``Geo.near``); returns (q.q, q.u_free, q.u^(n-1), S, below, close).

    S is the size of the Kirchhoff-Carrier tension rise (``Coefs.kc_s_skip``).  The counts are
    integers, which vectorise with the rest (a float min() does not).  They are taken unless
    ``count`` is False, which a string without fretboard and frets passes in every call
    (``_counted``): LLVM splits the loop in two versions on the flag, whose float sums it need
    not vectorise alike, so the flag must not differ between the loops that step one string."""
    qq = 0.0
    quf = 0.0
    qu1 = 0.0
    s2 = 0.0
    below = 0
    close = 0
    for j in range(n - 1):
        a = U0[j]
        b = U0[j + 1]
        m = U0[j + 2]
        d = U0[j + 3]
        e = U0[j + 4]
        u1 = U1[j + 2]
        uf = b0 * m + b1 * (b + d) + b2 * (a + e) + c0 * u1 + c1 * (U1[j + 1] + U1[j + 3])
        UF[j + 2] = uf
        qv = (b - 2.0 * m + d) * ih2
        Q[j] = qv
        qq += qv * qv
        quf += qv * uf
        qu1 += qv * u1
        dm = m - b
        s2 += dm * dm
        if count:
            below += m < board[j]
            close += m < near[j]
    last = U0[n]  # the interval from node N-1 to the fixed end
    return qq, quf, qu1, s2 + last * last, below, close


@njit(**JIT)
def _pass(n, b0, b1, b2, c0, c1, ih2, U0, U1, UF, board, near, count):
    """a) without Kirchhoff-Carrier: u_free, S and the counts (see ``_pass_kc``); returns
    (S, below, close)."""
    s2 = 0.0
    below = 0
    close = 0
    for j in range(n - 1):
        b = U0[j + 1]
        m = U0[j + 2]
        UF[j + 2] = (
            b0 * m
            + b1 * (b + U0[j + 3])
            + b2 * (U0[j] + U0[j + 4])
            + c0 * U1[j + 2]
            + c1 * (U1[j + 1] + U1[j + 3])
        )
        dm = m - b
        s2 += dm * dm
        if count:
            below += m < board[j]
            close += m < near[j]
    last = U0[n]
    return s2 + last * last, below, close


@njit(**JIT_HELPER)
def _counted(c, geo):
    """Does the linear pass count the nodes near a contact?  Not on a string without fretboard
    and frets (``benchmarks.speed``'s linear string), which has none to count; a property of the
    string, so every loop that steps it passes the same flag."""
    return c.board_k > 0.0 or geo.fret_p.shape[0] > 0


@njit(**JIT_HELPER)
def _ends(U0, n):
    """The ghost cells of the simply supported ends (eq. (2)), set at the start of every step."""
    U0[0] = -U0[2]
    U0[n + 2] = -U0[n]


@njit(**JIT_HELPER)
def _kc_multiplier(c, qq, quf, qu1):
    """The Kirchhoff-Carrier column alone (the common free-vibration step): a 1x1 system."""
    return -c.kc * (qu1 + quf) / (1.0 + c.kc * c.lam * qq)


@njit(**JIT_HELPER)
def _add_kc(n, UF, Q, a_):
    """z^(n+1) += Lambda x_KC q."""
    for j in range(n - 1):
        UF[j + 2] += a_ * Q[j]


@njit(**JIT_HELPER)
def _pickups(out_p, out_w0, out_w1, UF, U0, k, out, it):
    """Output: the string velocity (u^(n+1) - u^n) / k at each pickup."""
    for pk in range(out_p.shape[0]):
        po = out_p[pk]
        out[pk, it] = (
            out_w0[pk] * (UF[po] - U0[po]) + out_w1[pk] * (UF[po + 1] - U0[po + 1])
        ) / k


@njit(**JIT_HELPER)
def _q_index(p):
    """Index into Q (q = D u^n; Q[j] at node j + 1, so at padded node p = j + 2) of padded node p,
    unsigned so that numba leaves out the wrap-around of negative indices.  An interpolant in the
    first or last grid interval touches a fixed end (p = 1, or p + 1 = N + 1), which has no q and
    weight 0 (``interp``): node 1 is clamped to Q[0], and node N + 1 reads Q[N - 1], the element
    ``State.q`` carries past the N - 1 interior nodes, which stays 0.  (Wrapped, node 1 read the
    far end; without that element, node N + 1 read memory past Q.)"""
    return np.uint64(max(p - 2, 0))


@njit(**JIT_HELPER)
def _bent_stencil(c, tb_step, tb_ratio, step):
    """Bends and vibrato: T^n = T0 * ratio(step) enters B of eq. (50a); returns (ratio, b0, b1)."""
    ratio = _tension_ratio(tb_step, tb_ratio, step)
    dl = (ratio - 1.0) * c.lam2
    return ratio, c.b0 - 2.0 * dl / c.den, c.b1 + dl / c.den


@njit(**JIT_HELPER)
def _tension_ratio(tb_step, tb_ratio, step):
    """Piecewise-linear T / T0 between breakpoints (constant outside)."""
    m = tb_step.shape[0]
    if step <= tb_step[0]:
        return tb_ratio[0]
    if step >= tb_step[m - 1]:
        return tb_ratio[m - 1]
    lo = 0
    hi = m - 1
    while hi - lo > 1:
        mid = (lo + hi) // 2
        if tb_step[mid] <= step:
            lo = mid
        else:
            hi = mid
    a = (step - tb_step[lo]) / (tb_step[hi] - tb_step[lo])
    return tb_ratio[lo] + a * (tb_ratio[hi] - tb_ratio[lo])
