"""The gradient correction of sec. 4.7: the gamma of a contact's scalar-auxiliary-variable column from
its predicted psi (``_gamma``; the rule after eq. (61) as printed is sign-inconsistent, and the
engine's rule is the one documented there and in docs/engine.md), applied to a column's entries
(``_apply_gamma``), and decided on the joint solution for columns that act together
(``_joint_gamma``).  Any gamma keeps the energy balance exact.
"""

from __future__ import annotations

import math

from numba import njit

from ...config import JIT_HELPER
from .data import BOARD, FINGER, FRETPEN, GAMMA_JOINT, GAMMA_NONE, GAMMA_PAPER
from .finger import _finger_row


@njit(**JIT_HELPER)
def _gamma(psi, xi, s, in_contact, rule=GAMMA_JOINT):
    """Gradient correction of sec. 4.7, written so that its aim is explicit.

    In contact: gamma = 1 unless the predicted M_- psi^(n+1/2) (Sherman-Morrison with this column
    alone, eq. (57)) would be negative; then gamma = -4 psi / xi, which makes it zero (eq. (60)).
    Out of contact with a residual psi: the previous gradient is reused with the gamma that drives the
    predicted psi^(n+1/2) to zero, the root of smaller magnitude of
        (s psi / 4) gamma^2 - (xi / 2) gamma - psi = 0,
    where psi^(n+1/2) = 2 M_- psi - psi^(n-1/2) and M_- psi = (psi + gamma xi / 4) / (1 + gamma^2 s / 4).
    (The paper's lambda rule after eq. (61) serves this aim but reads sign-inconsistent; this form
    has no free constant.)  Any gamma keeps the discrete energy balance exact.
    ``rule`` selects a variant for the accuracy study (GAMMA_PAPER, GAMMA_NONE).
    """
    if rule == GAMMA_NONE:
        return 1.0 if in_contact else 0.0
    if in_contact:
        if 4.0 * psi + xi < 0.0 and xi != 0.0:
            return -4.0 * psi / xi
        return 1.0
    if rule == GAMMA_PAPER:  # eq. (61) as printed: lambda = 1/2 or 3/2 by the sign of -4 psi / xi
        if xi == 0.0:
            return 0.0
        g = -4.0 * psi / xi
        return (0.5 if g < 0.0 else 1.5) * g
    a = 0.25 * psi * s
    b = -0.5 * xi
    cc = -psi
    disc = b * b - 4.0 * a * cc
    if a == 0.0 or disc < 0.0:
        return 0.0
    qv = -0.5 * (b + math.copysign(math.sqrt(disc), b))
    if qv == 0.0:
        return 0.0
    return cc / qv


@njit(**JIT_HELPER)
def _apply_gamma(c, UF, U1, psi, which, contact, joint, cidx, cval, start, nent):
    """Scale the SAV column g~ in cval[start:nent] by its gamma; returns (nent, used, gamma, s~).

    With the engine's joint rule (``joint``) a contact column enters with gamma = 1 and
    ``_joint_gamma`` corrects it after the solve if needed; otherwise gamma follows ``_gamma`` on
    the column's own prediction.
    """
    xi = 0.0
    s = 0.0
    for e in range(start, nent):
        xi += cval[e] * (UF[cidx[e]] - U1[cidx[e]])
        s += cval[e] * cval[e]
    s *= c.lam
    if joint and contact:
        gm = 1.0
    else:
        gm = _gamma(psi[which], xi, s, contact, c.gamma_rule)
    if gm == 0.0 or nent == start:
        return start, False, 0.0, s
    if gm != 1.0:
        for e in range(start, nent):
            cval[e] *= gm
    return nent, True, gm, s


@njit(**JIT_HELPER)
def _joint_gamma(nbase, kind, cslot, cstart, cval, ca, cc, vfree, v1, x, G, cgam, cs, cbt, ccon,
                 psi, f_psi, fbeta, fchi, fr, k, nc):
    """The gradient correction of sec. 4.7 for columns that act together; True if any changed.

    ``_gamma`` predicts a column's psi from the free motion and its own force alone.  When a finger
    presses the string onto the fretboard, or two fingers share nodes, that prediction leaves out
    the other forces and can be badly wrong (the board's column dropped while the finger drives the
    string through it).  With the joint rule, contact columns enter the first solve with gamma = 1;
    here each one's predicted mean psi is read off that joint solution, and where it would pull
    (mean < 0 in contact) or leave a residual (out of contact), gamma is recomputed by the same
    rule with the prediction that includes every other column's force from the first solve.  The
    caller then solves once more.  Any gamma keeps the energy balance exact.  ``fr``: each finger
    slot's contact damping R in this step (``Work.fr``), k the time step.
    """
    changed = False
    for i in range(nbase):
        kd = kind[i]
        if kd != BOARD and kd != FRETPEN and kd != FINGER:
            continue
        gold = cgam[i]
        # v_i^T (z^(n+1) - z^(n-1)) in the first solve, and the part of it the column moved itself
        dz = vfree[i] - v1[i]
        for j in range(nc):
            dz += G[i, j] * x[j]
        own = G[i, i] * x[i]
        s_ = cslot[i]
        if kd == FINGER:
            ps = f_psi[s_]
            mean = ps + 0.25 * fbeta[s_] * dz
            xi = cbt[i] * (dz - own)
        else:
            ps = psi[kd - 1]
            mean = -x[i]  # x = -(psi^(n+1/2) + psi^(n-1/2)) / 2
            xi = (dz - own) / gold
        if ccon[i]:
            if mean >= 0.0:
                continue
            gnew = _gamma(ps, xi, cs[i], True)
            if gnew >= gold:
                continue
        else:
            gnew = _gamma(ps, xi, cs[i], False)
            if abs(gnew - gold) <= 1e-9 * abs(gold):
                continue
        changed = True
        cgam[i] = gnew
        if kd == FINGER:
            bt = gnew * cbt[i]
            fbeta[s_] = bt
            cc[i], ca[i] = _finger_row(bt, ps, v1[i], fchi[s_], fr[s_] / (2.0 * k))
        else:
            f = gnew / gold
            for e in range(cstart[i], cstart[i + 1]):
                cval[e] *= f
            vfree[i] *= f
            v1[i] *= f
            ca[i] = ps - 0.25 * v1[i]
    return changed
