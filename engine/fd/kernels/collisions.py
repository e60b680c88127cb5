"""The collisions: the fretboard's SAV gradient, eqs. (7) and (54)-(55a); the frets, either as penalty
SAV contacts, eqs. (8), (24b) and (55b), or as one-sided rigid constraints (the K_F -> infinity
limit: the active set's columns and the check that no other fret is penetrated); the quiet run's
question whether any contact acts at all.  The finger, the third kind of contact, has a module of
its own (``finger``).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit, types
from numba.core import cgutils
from numba.core import config as numba_config
from numba.extending import intrinsic

from ...config import JIT_HELPER, JIT_STEP
from .data import EPS, RIGID
from .linear import _q_index
from .sav import _apply_gamma


@intrinsic
def _borrowed(typingctx, arr):
    """``arr`` as a view that holds no reference (its meminfo and parent null): for a call in a
    step loop whose caller holds ``arr`` for the whole call, so that the reference counts the
    callee's inlined body makes are on nothing (``engine.config``: numba's pruner left them in
    the held run's loop, atomic operations in every step).  Only for such calls: the view must
    not outlive the array it borrows."""
    if not isinstance(arr, types.Array):
        return None

    def codegen(context, builder, signature, args):
        ary = context.make_array(arr)(context, builder, value=args[0])
        ary.meminfo = cgutils.get_null_value(ary.meminfo.type)
        ary.parent = cgutils.get_null_value(ary.parent.type)
        return ary._getvalue()

    return arr(arr), codegen


if numba_config.DISABLE_JIT:  # the kernels run as Python (NUMBA_DISABLE_JIT=1): nothing is counted
    def _borrowed(arr):  # noqa: F811
        return arr


@njit(**JIT_STEP)
def _contact(c, below, close, UF, du, Q, fret_p, fret_w0, fret_w1, fret_m0, fret_active, nfret,
             kq):
    """Does a contact act in a step with no other force (see ``_quiet_run``), given the counts of
    the linear pass, of which one is not 0?  Not inlined: a branch that the quiet steps of a
    soft pluck rarely take (inlined, it slowed their loop)."""
    if below > 0 and c.board_k > 0.0:  # below the Hertzian board is contact
        return True
    if c.fret_mode != 1:  # penalty frets act on u^n: within reach is all there is to know
        return True
    return _fret_hit(c.kc > 0.0, close > 0, below > 0, _borrowed(UF), _borrowed(du),
                     _borrowed(Q), _borrowed(fret_p), _borrowed(fret_w0), _borrowed(fret_w1),
                     _borrowed(fret_m0), _borrowed(fret_active), nfret, kq) >= 0


@njit(**JIT_HELPER)
def _fret_hit(with_q, with_frets, with_board, UF, du, Q, fret_p, fret_w0, fret_w1, fret_m0,
              fret_active, nfret, kq):
    """The rigid constraints' active-set check: the one outside the active set that the predicted
    u^(n+1) = u_free + du + kq q penetrates deepest (by more than 1e-12 m); -1 if none.  With
    ``with_frets`` (a fret outside the active set is within reach) every fret is looked at, and
    with ``with_board`` (a node is within reach of a rigid board) every node of the board: which
    constraint is added must not depend on the skip's margin.

    The indices are unsigned (see ``_q_index``): numba's wrap-around of negative indices cost a
    measurable share of a fretted step in this loop (``benchmarks.speed``), and kept LLVM from
    vectorising the board's count."""
    add = -1
    wval = -1e-12
    if with_frets:
        for q in range(nfret):
            p_ = fret_p[q]
            p0 = np.uint64(p_)
            p1 = np.uint64(p_ + 1)
            pv = fret_w0[q] * (UF[p0] + du[p0]) + fret_w1[q] * (UF[p1] + du[p1])
            if with_q:
                pv += kq * (fret_w0[q] * Q[_q_index(p_)] + fret_w1[q] * Q[_q_index(p_ + 1)])
            viol = pv - fret_m0[q]
            if viol < wval and fret_active[q] == 0:
                wval = viol
                add = q
    nb = fret_p.shape[0] - nfret
    if with_board and nb > 0:
        # the board's nodes: weight 1 on consecutive nodes (``Geo``), first counted in a loop
        # LLVM vectorises (an integer sum), then searched only if one is penetrated; both loops
        # take the gap from ``_board_gap``, so the count and the search agree
        j0 = np.uint64(fret_p[nfret])
        m0 = np.uint64(nfret)
        hit = 0
        for i in range(nb):
            hit += _board_gap(with_q, UF, du, Q, fret_m0, j0, m0, np.uint64(i), kq) < -1e-12
        if hit > 0:
            for i in range(nb):
                ui = np.uint64(i)
                viol = _board_gap(with_q, UF, du, Q, fret_m0, j0, m0, ui, kq)
                if viol < wval and fret_active[m0 + ui] == 0:
                    wval = viol
                    add = nfret + i
    return add


@njit(**JIT_HELPER)
def _board_gap(with_q, UF, du, Q, fret_m0, j0, m0, i, kq):
    """How far the predicted u^(n+1) = u_free + du + kq q is above the board at its i-th node
    (padded index j0 + i, constraint m0 + i, ``Geo``): negative where it penetrates."""
    pv = UF[j0 + i] + du[j0 + i]
    if with_q:
        pv += kq * Q[j0 - np.uint64(2) + i]
    return pv - fret_m0[m0 + i]


@njit(**JIT_HELPER)
def _sav_board(c, U0, U1, UF, board, psi, gprev, has_gprev, contact, joint, cidx, cval, nent,
               scr):
    """Fretboard column g_B = gamma * g~_B, eqs. (24a), (54), (55a); returns (nent, used, gamma,
    s~) (see ``_apply_gamma``)."""
    n = c.n
    start = nent
    if contact:
        vpot = 0.0
        for j in range(n - 1):
            pen = board[j] - U0[j + 2]
            if pen > 0.0:
                vpot += c.h * c.board_k / (c.board_alpha + 1.0) * pen ** (c.board_alpha + 1.0)
        den = math.sqrt(2.0 * vpot + EPS)
        for j in range(n - 1):
            pen = board[j] - U0[j + 2]
            if pen > 0.0:
                cidx[nent] = j + 2
                cval[nent] = -c.h * c.board_k * pen**c.board_alpha / den
                nent += 1
        # keep the gradient for the out-of-contact rule
        gprev[:] = 0.0
        for e in range(start, nent):
            gprev[cidx[e]] = cval[e]
        has_gprev[0] = 1
    else:
        if not has_gprev[0]:
            return nent, False, 0.0, 0.0
        for j in range(n - 1):
            if gprev[j + 2] != 0.0:
                cidx[nent] = j + 2
                cval[nent] = gprev[j + 2]
                nent += 1
    return _apply_gamma(c, UF, U1, psi, 0, contact, joint, cidx, cval, start, nent)


@njit(**JIT_HELPER)
def _sav_frets(c, U0, U1, UF, psi, gprev, has_gprev, fret_p, fret_w0, fret_w1, fret_m0,
               joint, cidx, cval, nent, scr):
    """Penalty frets as one SAV, eqs. (24b), (54), (55b) (NOTES.md form); returns (nent, used,
    gamma, s~, contact)."""
    start = nent
    vpot = 0.0
    nf = fret_p.shape[0]
    contact = False
    for q in range(nf):
        p_ = fret_p[q]
        pen = fret_m0[q] - (fret_w0[q] * U0[p_] + fret_w1[q] * U0[p_ + 1])
        if pen > 0.0:
            contact = True
            vpot += c.fret_k / (c.fret_alpha + 1.0) * pen ** (c.fret_alpha + 1.0)
    if contact:
        den = math.sqrt(2.0 * vpot + EPS)
        for q in range(nf):
            p_ = fret_p[q]
            pen = fret_m0[q] - (fret_w0[q] * U0[p_] + fret_w1[q] * U0[p_ + 1])
            if pen > 0.0:
                f = -c.fret_k * pen**c.fret_alpha / den
                scr[p_] += f * fret_w0[q]
                scr[p_ + 1] += f * fret_w1[q]
        gprev[:] = 0.0
        for q in range(nf):
            p_ = fret_p[q]
            for pp in (p_, p_ + 1):
                if scr[pp] != 0.0:
                    cidx[nent] = pp
                    cval[nent] = scr[pp]
                    gprev[pp] = scr[pp]
                    scr[pp] = 0.0
                    nent += 1
        has_gprev[1] = 1
    else:
        if psi[1] == 0.0 or not has_gprev[1]:
            return nent, False, 0.0, 0.0, False
        for q in range(nf):
            p_ = fret_p[q]
            for pp in (p_, p_ + 1):
                if gprev[pp] != 0.0 and scr[pp] == 0.0:
                    scr[pp] = 1.0
                    cidx[nent] = pp
                    cval[nent] = gprev[pp]
                    nent += 1
        for e in range(start, nent):
            scr[cidx[e]] = 0.0
    nent, used, gm, s = _apply_gamma(c, UF, U1, psi, 1, contact, joint, cidx, cval, start, nent)
    return nent, used, gm, s, contact


@njit(**JIT_HELPER)
def _rigid_row(q, fret_p, fret_w0, fret_w1, UF, U1):
    """A rigid fret's j_q.u_free and j_q.u^(n-1): (v_free, v1) of its row."""
    p_ = fret_p[q]
    return (fret_w0[q] * UF[p_] + fret_w1[q] * UF[p_ + 1],
            fret_w0[q] * U1[p_] + fret_w1[q] * U1[p_ + 1])


@njit(**JIT_HELPER)
def _add_rigid(q, nc, kind, cslot, cfret, cstart, cidx, cval, nent, fret_p, fret_w0, fret_w1,
               fret_m0, UF, U1, ca, vfree, v1):
    p_ = fret_p[q]
    kind[nc] = RIGID
    cslot[nc] = -1
    cfret[nc] = q
    cidx[nent] = p_
    cval[nent] = fret_w0[q]
    cidx[nent + 1] = p_ + 1
    cval[nent + 1] = fret_w1[q]
    ca[nc] = fret_m0[q]
    vfree[nc], v1[nc] = _rigid_row(q, fret_p, fret_w0, fret_w1, UF, U1)
    cstart[nc + 1] = nent + 2
    return nent + 2


@njit(**JIT_HELPER)
def _remove_col(i, nc, kind, cslot, cfret, cstart, cidx, cval, ca, cc, vfree, v1, xp):
    """Remove column i (a rigid fret, always stored after the others) and compact the storage."""
    width = cstart[i + 1] - cstart[i]
    for m in range(i, nc - 1):
        kind[m] = kind[m + 1]
        cslot[m] = cslot[m + 1]
        cfret[m] = cfret[m + 1]
        ca[m] = ca[m + 1]
        cc[m] = cc[m + 1]
        vfree[m] = vfree[m + 1]
        v1[m] = v1[m + 1]
        xp[m] = xp[m + 1]
        for e in range(cstart[m + 1], cstart[m + 2]):
            cidx[e - width] = cidx[e]
            cval[e - width] = cval[e]
        cstart[m + 1] = cstart[m + 2] - width
    return nc - 1
