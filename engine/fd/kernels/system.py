"""The small system of a step.  Every nonlinear force enters z^(n+1) = z_free + Lambda sum_c v_c x_c,
and the column multipliers x_c are solved for directly: the Woodbury identity of sec. 4.6 without
forming b^n of eq. (49) and correcting it, which broke the energy balance for large gamma
(``../shared/papers/NOTES.md``, docs/engine.md).  Here: the Gram matrix v_i^T Lambda v_j, the
system's rows, its solves (an arrowhead without pivot search, anything else by Gaussian
elimination with partial pivoting), the rigid frets' active-set steps, and the scatter of the
columns' forces onto the string.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ...config import JIT, JIT_HELPER
from .data import KC, RIGID
from .linear import _q_index


@njit(**JIT_HELPER)
def _solve(A, r, n):
    """Solve A x = r in place (x into r); returns False if A is singular.

    The system is that of the column multipliers: with each non-rigid row divided by its c, it
    is symmetric, and positive definite unless rigid constraints depend on each other.  Most
    systems are arrowheads: the Kirchhoff-Carrier column (or the one column that is not narrow)
    couples to every other, and the narrow columns of a finger and of frets away from it share no
    node.  These are solved by eliminating the narrow columns into the first row
    (``_solve_arrow``): a handful of operations and no pivot search (docs/engine.md names the
    speed-up it measured).  Any other system goes to
    Gaussian elimination with partial pivoting (``_solve_n``).  Sizes 2 to 4 are literal, so
    LLVM unrolls the loops; the four-column arrowhead is a held fretted note's system:
    Kirchhoff-Carrier, the finger, and the two frets the pressed string rests on."""
    if n == 4:  # literal sizes: LLVM unrolls the loops
        return _solve_sized(A, r, 4)
    if n == 3:
        return _solve_sized(A, r, 3)
    if n == 2:
        return _solve_sized(A, r, 2)
    return _solve_sized(A, r, n)


@njit(**JIT_HELPER)
def _solve_sized(A, r, n):
    """``_solve`` for a size that is a literal where the caller can make it one."""
    if _is_arrow(A, n):
        return _solve_arrow(A, r, n)
    return _solve_n(A, r, n)


@njit(**JIT_HELPER)
def _is_arrow(A, n):
    """Do rows and columns 1..n-1 of A meet only in row and column 0, on a diagonal of non-zero
    entries?"""
    for i in range(1, n):
        if A[i, i] == 0.0:
            return False
        for j in range(1, n):
            if i != j and A[i, j] != 0.0:
                return False
    return True


@njit(**JIT_HELPER)
def _solve_arrow(A, r, n):
    """An arrowhead system, in place: x_1..x_(n-1) eliminated into row 0, whose Schur complement
    s = A_00 - sum_i A_0i A_i0 / A_ii gives x_0, then x_i = (r_i - A_i0 x_0) / A_ii.  Without
    pivoting: scaled as above, these are the pivots of a symmetric positive definite matrix
    (Cholesky's order), which need none.  False if s is zero (dependent rigid constraints) or
    NaN."""
    s = A[0, 0]
    t = r[0]
    for i in range(1, n):
        g = A[0, i] / A[i, i]
        s -= g * A[i, 0]
        t -= g * r[i]
    if not (s > 0.0 or s < 0.0):
        return False
    x0 = t / s
    r[0] = x0
    for i in range(1, n):
        r[i] = (r[i] - A[i, 0] * x0) / A[i, i]
    return True


@njit(**JIT_HELPER)
def _solve_n(A, r, n):
    """Gaussian elimination with partial pivoting, in place; returns False if singular."""
    for i in range(n):
        p = i
        big = abs(A[i, i])
        for m in range(i + 1, n):
            if abs(A[m, i]) > big:
                big = abs(A[m, i])
                p = m
        if not big > 0.0:
            return False
        if p != i:
            for m in range(n):
                t = A[i, m]
                A[i, m] = A[p, m]
                A[p, m] = t
            t = r[i]
            r[i] = r[p]
            r[p] = t
        piv = A[i, i]
        for m in range(i + 1, n):
            f = A[m, i] / piv
            if f != 0.0:
                for l in range(i, n):
                    A[m, l] -= f * A[i, l]
                r[m] -= f * r[i]
    for i in range(n - 1, -1, -1):
        s = r[i]
        for m in range(i + 1, n):
            s -= A[i, m] * r[m]
        r[i] = s / A[i, i]
    return True


@njit(**JIT_HELPER)
def _assemble(nc, kind, ca, cc, vfree, G, A, b):
    """The system of the multipliers from the Gram matrix: rows of the non-rigid columns
    x + c (G x + v_free) = -a (eqs. (55)-(56)), rigid rows G x = m0 - v_free."""
    for i in range(nc):
        for j in range(nc):
            if kind[i] == RIGID:
                A[i, j] = G[i, j]
            else:
                A[i, j] = cc[i] * G[i, j]
        if kind[i] == RIGID:
            b[i] = ca[i] - vfree[i]
        else:
            A[i, i] += 1.0
            b[i] = -ca[i] - cc[i] * vfree[i]


@njit(**JIT)
def _step_to_zero(x, xp, nbase, nc):
    """Lawson and Hanson's step: xp (every rigid reaction >= 0) moves towards the solve x, which
    has a negative one, until the first rigid reaction reaches zero; returns that column.  Not
    inlined, like ``_ray_blocked``: both are rarely taken, and inlined they slowed every fretted
    step."""
    alpha = 1.0
    worst = -1
    for i in range(nbase, nc):
        if x[i] < 0.0:
            a = xp[i] / (xp[i] - x[i])
            if a < alpha:
                alpha = a
                worst = i
    for i in range(nc):
        xp[i] += alpha * (x[i] - xp[i])
    xp[worst] = 0.0
    return worst


@njit(**JIT)
def _ray_blocked(nc, nbase, kind, cstart, cidx, cval, cslot, Q, qq, lam, lam_f, ca, cc, vfree,
                 xp, G, A, b, scr, d, A2):
    """A rigid fret (the last of the nc columns) was just added to xp, a solution of the others
    with every rigid reaction >= 0 (xp of the new column is 0).  Does the way to the joint
    solution meet a zero reaction first?  If so, xp is moved there and the column of the fret
    that leaves is returned; -1 if not.  G, A, b, d and A2 are scratch (d and A2 of at least
    nc - 1 rows).

    In the QP of the active-set loop, with H = the system's rows scaled symmetric, the direction
    that keeps the other columns' gradients at zero while the new reaction grows is
    d = (-H_PP^-1 H_Pj, 1) (solved with the rows of A, which are H's scaled by positive numbers);
    along it the objective changes by g_j t + s t^2 / 2, with g_j < 0 the new fret's gap and
    s = H_jj + H_jP d_P its Schur complement, so t* = -g_j / s is the joint solution.  A rigid
    reaction that d reduces reaches zero at t_i = xp_i / -d_i; if the first such t comes before
    t*, the step stops there and that fret leaves.  It always does when the new fret depends on
    the others (s = 0 up to rounding: crowded frets), where the joint system is singular or so
    ill-conditioned that its multipliers would break the energy balance.  Not inlined: called
    only when a fret is added.  It assembles the system itself, and the loop assembles it again
    before its solve: once per added fret, the price of keeping a flag for it out of the loop."""
    _gram(nc, kind, cstart, cidx, cval, cslot, Q, qq, lam, lam_f, G, scr)
    _assemble(nc, kind, ca, cc, vfree, G, A, b)
    m = nc - 1
    gj = -b[m]
    for i in range(m):
        gj += A[m, i] * xp[i]
        d[i] = -A[i, m]
        for l in range(m):
            A2[i, l] = A[i, l]
    if m > 0 and not _solve(A2, d, m):
        return -1
    s = A[m, m]
    for i in range(m):
        s += A[m, i] * d[i]
    tb = math.inf
    blk = -1
    for i in range(nbase, m):
        if d[i] < 0.0:
            t = xp[i] / -d[i]
            if t < tb:
                tb = t
                blk = i
    if blk < 0 or (s > 0.0 and tb * s >= -gj):
        return -1
    for i in range(m):
        xp[i] += tb * d[i]
    xp[blk] = 0.0
    xp[m] = tb
    return blk


@njit(**JIT_HELPER)
def _gram_kc(i, nc, cstart, cidx, cval, Q, qq, lam, G):
    """Row and column i of G, the Kirchhoff-Carrier column's: q.q, and q against each sparse
    column on its nodes."""
    G[i, i] = lam * qq
    for j in range(nc):
        if j == i:
            continue
        t = 0.0
        for e in range(cstart[j], cstart[j + 1]):
            t += Q[_q_index(np.int64(cidx[e]))] * cval[e]
        G[i, j] = lam * t
        G[j, i] = lam * t


@njit(**JIT_HELPER)
def _gram(nc, kind, cstart, cidx, cval, cslot, Q, qq, lam, lam_f, G, scr):
    """G[i, j] = v_i^T Lambda v_j for the active columns (the Woodbury core matrix).

    A sparse column holds each node once, so its diagonal entry is its sum of squares.  Two
    columns meet on the nodes they share: found by comparing indices when either is narrow (a
    finger's or a fret's two nodes), by scattering one into ``scr`` when both are wide (the
    fretboard against the penalty frets)."""
    for i in range(nc):
        if kind[i] == KC:
            _gram_kc(i, nc, cstart, cidx, cval, Q, qq, lam, G)
            continue
        s = 0.0
        for e in range(cstart[i], cstart[i + 1]):
            s += cval[e] * cval[e]
        s *= lam
        if cslot[i] >= 0:
            s += lam_f  # the finger's own entry (-1)(-1)
        G[i, i] = s
        for j in range(i + 1, nc):
            if kind[j] == KC:
                continue
            s = 0.0
            if cstart[i + 1] - cstart[i] <= 2 or cstart[j + 1] - cstart[j] <= 2:
                for e in range(cstart[i], cstart[i + 1]):
                    ie = cidx[e]
                    for f in range(cstart[j], cstart[j + 1]):
                        if cidx[f] == ie:
                            s += cval[e] * cval[f]
            else:
                for e in range(cstart[i], cstart[i + 1]):
                    scr[cidx[e]] = cval[e]
                for f in range(cstart[j], cstart[j + 1]):
                    s += scr[cidx[f]] * cval[f]
                for e in range(cstart[i], cstart[i + 1]):
                    scr[cidx[e]] = 0.0
            G[i, j] = lam * s  # a finger slot has one column: lam_f only on the diagonal
            G[j, i] = lam * s


@njit(**JIT_HELPER)
def _scatter(nc, kind, cstart, cidx, cval, x, lam, du):
    """du += Lambda * sum of the sparse columns' forces (du: a scratch, or z itself); returns the
    KC multiplier."""
    xk = 0.0
    for ci in range(nc):
        if kind[ci] == KC:
            xk = x[ci]
            continue
        for e in range(cstart[ci], cstart[ci + 1]):
            du[cidx[e]] += lam * cval[e] * x[ci]
    return xk


@njit(**JIT_HELPER)
def _unscatter(nc, cstart, cidx, du):
    for e in range(cstart[0], cstart[nc]):
        du[cidx[e]] = 0.0
