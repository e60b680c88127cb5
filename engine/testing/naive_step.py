"""A plain-NumPy reference of one complete time step of the DAFx24 scheme, the way STUMPY keeps
naive versions of its kernels: no stencils, no sparse columns, no skips, no specialised loops.

Everything is dense and written from the paper's equations (the numbers of Bilbao, Russo, Webb &
Ducceschi 2024), not from the kernels' code:

* the linear update z_free = B u^n + C u^(n-1) (eqs. (36), (50a-b)) with B and C formed as dense
  matrices from T, E I, sigma0, sigma1 and the Dirichlet second difference D (simply supported
  ends, eq. (2)), and the pluck forces through their interpolants (eqs. (5), (15), (19));
* every nonlinear force as a dense column v_c of the joint state z = [u; w] (string nodes, then
  one entry per finger mass), z^(n+1) = z_free + Lambda V x, with one linear equation per
  multiplier x_c:
    Kirchhoff-Carrier   x = -kc q.(u^(n+1) + u^(n-1)),  q = D u^n                 eqs. (37), (52)
    fretboard SAV       x = -(psi + g.(u^(n+1) - u^(n-1)) / 4),  g = gamma grad V / sqrt(2 V + eps)
                                                                       eqs. (24a), (54), (55a)
    penalty frets       the same with V of eq. (8) and the fret interpolants       eq. (55b)
    finger              x = -beta (psi_f + beta d_eta / 4) - chi R d_eta / (2 k),
                        eta = j.u - w, d_eta = eta^(n+1) - eta^(n-1)   eqs. (25)-(27), (55c-d)
    damper              x = -R d(v.u) / (2 k)
    rigid fret          j_q.u^(n+1) = m0_q, x_q >= 0 (the K_F -> infinity limit of eq. (8));
    rigid board         u_p^(n+1) = b_p, x_p >= 0 at a node p (the K_B -> infinity limit of eq. (7))
* the multipliers from the dense matrix I + diag(c) V^T Lambda V (rigid rows V^T Lambda V),
  solved with ``numpy.linalg.solve``; the rigid frets' active set by the plain sign rule (drop the
  most negative reaction, else add the deepest penetrated fret), which reaches the same unique
  solution of the QP as the kernels' Lawson-Hanson loop wherever it does not cycle;
* the gradient correction gamma of sec. 4.7 decided on the joint solution (docs/engine.md):
  contact columns enter with gamma = 1; a column whose predicted mean psi would pull (or that
  keeps a residual psi out of contact) gets the rule's gamma from a prediction that includes the
  other columns' forces, then one more solve;
* the psi updates of eq. (48), the fingers' positions, the pickups' velocity.

Every fret and node of a rigid board is checked in every step (the kernels look at them only
within a margin of a tip or of the board), so a skip that missed a contact would show as a
difference.  ``naive_step`` takes the kernels' own
inputs (``Coefs``, ``Geo``, ``Controls``, ``State``) and returns the state after the step as a
dict; ``tests/engine/kernels/test_naive_step.py`` compares it with ``kernels.step_block``.
"""

from __future__ import annotations

import math
from decimal import Decimal, localcontext

import numpy as np

from engine.fd.kernels import EPS, GAMMA_JOINT, GAMMA_NONE, GAMMA_PAPER
from engine.testing.scenes import fret, pluck, scene, tap

IDLE, ACTIVE, GONE = 0, 1, 2


def second_difference(n: int, h: float) -> np.ndarray:
    """D: the (N-1) x (N-1) second difference with u_0 = u_N = 0 (eq. (2))."""
    d = -2.0 * np.eye(n - 1) + np.eye(n - 1, k=1) + np.eye(n - 1, k=-1)
    return d / (h * h)


def interpolant(x: float, h: float, n: int) -> np.ndarray:
    """j(x) of eqs. (15)-(16) as a dense vector over the interior nodes 1..N-1 (the weights on the
    fixed ends vanish with the ends' displacement)."""
    s = x / h
    l = min(max(int(math.floor(s)), 0), n - 1)
    a = s - l
    j = np.zeros(n - 1)
    if 1 <= l <= n - 1:
        j[l - 1] += 1.0 - a
    if 1 <= l + 1 <= n - 1:
        j[l] += a
    return j


def padded_interpolant(p: int, w0: float, w1: float, n: int) -> np.ndarray:
    """The dense j of an interpolant given as (padded left node, weights), as ``Geo`` stores it."""
    j = np.zeros(n - 1)
    for pp, ww in ((p, w0), (p + 1, w1)):
        if 1 <= pp - 1 <= n - 1:
            j[pp - 2] += ww
    return j


def finger_x(x0, x1, ms, me, step):
    """The finger's place at a step: a straight glide from x0 at step ms to x1 at step me (a
    slide), held before and after; a glide that takes no steps is a jump at ms."""
    if me <= ms:
        return x1 if step >= ms else x0
    return float(np.interp(step, (ms, me), (x0, x1)))


def gamma(psi, xi, s, in_contact, rule=GAMMA_JOINT):
    """Sec. 4.7's gradient correction as docs/engine.md states it, with the predicted mean psi
    M_- psi = (psi + gamma xi / 4) / (1 + gamma^2 s / 4) (s >= 0):

    * in contact, gamma = 1 unless that prediction would be negative at gamma = 1; then the gamma
      that makes it zero, -4 psi / xi (eq. (60));
    * out of contact, the gamma that drives the predicted psi^(n+1/2) = 2 M_- psi - psi to zero,
      a root of (s psi / 4) gamma^2 - (xi / 2) gamma - psi = 0: the one of smaller magnitude
      (``_drive_to_zero``); 0 where there is none (or where s = 0: the column is zero, and no gamma
      moves psi)."""
    if rule == GAMMA_NONE:
        return 1.0 if in_contact else 0.0
    if in_contact:
        if (psi + xi / 4.0) / (1.0 + s / 4.0) < 0.0 and xi != 0.0:
            return -4.0 * psi / xi
        return 1.0
    if rule == GAMMA_PAPER:
        if xi == 0.0:
            return 0.0
        g = -4.0 * psi / xi
        return (0.5 if g < 0.0 else 1.5) * g
    return _drive_to_zero(psi, xi, s)


def _drive_to_zero(psi: float, xi: float, s: float) -> float:
    """The real root of smaller magnitude of a g^2 + b g + c, a = s psi / 4, b = -xi / 2,
    c = -psi, or 0 if it has none (or a = 0).  Solved by the textbook formula
    (-b +- sqrt(b^2 - 4 a c)) / (2 a) in decimal arithmetic from the floats' exact values
    (``Decimal(float)`` is exact), not by the kernels' cancellation-free float formula.  The small
    root cancels about log10(b^2 / |4 a c|) digits (hundreds where a finger's residual psi has
    decayed to 1e-110 and below, out of contact), so the precision is that many digits plus 60:
    the rounding to float is the only error left."""
    if s == 0.0 or psi == 0.0:
        return 0.0
    lost = 0
    if xi != 0.0:  # log10(b^2) - log10(|4 a c|), 4 a c = -s psi^2
        lost = max(0, math.ceil(2.0 * math.log10(abs(xi) / 2.0) - math.log10(s)
                                - 2.0 * math.log10(abs(psi))))
    with localcontext() as ctx:
        ctx.prec = 60 + lost
        a = Decimal(s) * Decimal(psi) / 4
        b = -Decimal(xi) / 2
        c = -Decimal(psi)
        disc = b * b - 4 * a * c
        if disc < 0:
            return 0.0
        r = disc.sqrt()
        return float(min(((-b + r) / (2 * a), (-b - r) / (2 * a)), key=abs))


class _Col:
    """One column: its dense vector over z, its kind, and the row x = alpha - c v.z^(n+1)
    (penalty-like) or v.z^(n+1) = m0 (rigid)."""

    def __init__(self, kind, v, c=0.0, alpha=0.0, m0=0.0, **extra):
        self.kind, self.v, self.c, self.alpha, self.m0 = kind, v, c, alpha, m0
        self.__dict__.update(extra)


def _solve(cols, zfree, lam_z):
    """The multipliers of the columns: the dense system, by numpy.linalg.solve."""
    m = len(cols)
    if m == 0:
        return np.zeros(0)
    V = np.stack([c.v for c in cols], axis=1)
    G = V.T @ (lam_z[:, None] * V)
    A = np.empty((m, m))
    r = np.empty(m)
    for i, c in enumerate(cols):
        if c.kind.startswith("rigid"):
            A[i] = G[i]
            r[i] = c.m0 - c.v @ zfree
        else:
            A[i] = c.c * G[i]
            A[i, i] += 1.0
            r[i] = c.alpha - c.c * (c.v @ zfree)
    return np.linalg.solve(A, r)


def _predict(cols, x, zfree, lam_z):
    z = zfree.copy()
    for c, xc in zip(cols, x, strict=True):
        z += lam_z * c.v * xc
    return z


def naive_step(c, geo, ctl, st, step: int, rule: int | None = None) -> dict:
    """One step n -> n+1 from the kernels' inputs; returns the state after it (u, u1, psi, the
    fingers' f_state, f_w, f_w1, f_psi, f_bprev, the fretboard's gprev_b, the rigid frets'
    fret_active) and ``out`` (the velocity at each pickup) as arrays.  ``st`` is not changed."""
    rule = c.gamma_rule if rule is None else rule
    joint = rule == GAMMA_JOINT
    n, k, h = c.n, c.k, c.h
    ni = n - 1
    u0 = st.u[2:n + 1].copy()
    u1 = st.u1[2:n + 1].copy()
    nslot = len(ctl.fs_on)
    f_state = st.f_state.copy()
    f_w, f_w1 = st.f_w.copy(), st.f_w1.copy()
    f_psi, f_bprev = st.f_psi.copy(), st.f_bprev.copy()
    psi = st.psi.copy()
    gprev_b = st.gprev_b[2:n + 1].copy()
    gprev_f = st.gprev_f[2:n + 1].copy()
    has_gprev = st.has_gprev.copy()
    fret_active = st.fret_active.copy()

    # ---- the linear update, eqs. (36), (50a-b): B, C dense from the physics -------------------
    rho_a = c.rho_a_h / h
    ratio = float(np.interp(step, ctl.tb_step, ctl.tb_ratio)) if len(ctl.tb_step) else 1.0
    tension = c.t0 * ratio
    D = second_difference(n, h)
    eye = np.eye(ni)
    den = 1.0 + c.sigma0 * k
    B = (2.0 * eye + k * k / rho_a * (tension * D - c.ei * D @ D) + 2.0 * c.sigma1 * k * D) / den
    C = (-(1.0 - c.sigma0 * k) * eye - 2.0 * c.sigma1 * k * D) / den
    lam = k * k / (rho_a * h * den)  # Lambda, eq. (51): a point force f moves u_free by lam f
    lam_f = k * k / c.fg_mass
    uf = B @ u0 + C @ u1
    # ---- plucks, eq. (5) ----------------------------------------------------------------------
    for e in range(len(ctl.pl_start)):
        m = step - ctl.pl_start[e]
        if 0 <= m <= ctl.pl_len[e]:
            f = ctl.pl_amp[e] * math.sin(0.5 * math.pi * m / ctl.pl_len[e]) ** 2
            uf += lam * f * padded_interpolant(ctl.pl_p[e], ctl.pl_w0[e], ctl.pl_w1[e], n)

    # ---- the fingers' life cycle and free motion, eq. (39) -----------------------------------
    inject = 0.0
    wfree = np.zeros(nslot)
    fj = [None] * nslot
    for s in range(nslot):
        if f_state[s] == IDLE and step >= ctl.fs_on[s]:
            f_state[s] = ACTIVE
            j = interpolant(finger_x(ctl.fs_x0[s], ctl.fs_x1[s], ctl.fs_ms[s], ctl.fs_me[s],
                                     step), h, n)
            f_w[s] = j @ u0 + ctl.fs_gap[s]
            f_w1[s] = f_w[s] + ctl.fs_v0[s] * k
            f_psi[s] = 0.0
            f_bprev[s] = 0.0
            inject += 0.5 * c.fg_mass * ctl.fs_v0[s] ** 2
        if f_state[s] != ACTIVE:
            continue
        j = interpolant(finger_x(ctl.fs_x0[s], ctl.fs_x1[s], ctl.fs_ms[s], ctl.fs_me[s], step),
                        h, n)
        fj[s] = j
        eta = j @ u0 - f_w[s]
        if step >= ctl.fs_rel[s]:
            if -eta > c.fg_lift and f_w[s] > f_w1[s]:
                f_state[s] = GONE
                continue
            fext = ctl.fs_force[s]
        else:
            fext = -ctl.fs_force[s]
        wfree[s] = 2.0 * f_w[s] - f_w1[s] + lam_f * fext

    # the joint state z = [u; w], its free update and Lambda
    zfree = np.concatenate([uf, wfree])
    z1 = np.concatenate([u1, f_w1])
    lam_z = np.concatenate([np.full(ni, lam), np.full(nslot, lam_f)])

    def on_string(v):
        return np.concatenate([v, np.zeros(nslot)])

    cols = []
    # ---- Kirchhoff-Carrier, eqs. (37), (52) ---------------------------------------------------
    q = D @ u0
    if c.kc > 0.0:
        vq = on_string(q)
        cols.append(_Col("kc", vq, c=c.kc, alpha=-c.kc * (q @ u1)))

    # ---- fretboard SAV, eqs. (24a), (54), (55a) ------------------------------------------------
    def sav(which, gt, contact):
        xi = gt @ (uf - u1)
        s_ = lam * (gt @ gt)
        g = 1.0 if joint and contact else gamma(psi[which], xi, s_, contact, rule)
        if g == 0.0 or not np.any(gt):
            return
        v = on_string(g * gt)
        cols.append(_Col("sav", v, c=0.25, alpha=-psi[which] + 0.25 * (v @ z1), which=which,
                         gt=on_string(gt), gam=g, s=s_, contact=contact))

    board = geo.board
    if c.board_k > 0.0:
        pen = np.maximum(board - u0, 0.0)
        contact = bool(np.any(pen > 0.0))
        if contact:
            vpot = np.sum(h * c.board_k / (c.board_alpha + 1.0) * pen ** (c.board_alpha + 1.0))
            gt = -h * c.board_k * pen ** c.board_alpha / math.sqrt(2.0 * vpot + EPS)
            gprev_b = gt.copy()
            has_gprev[0] = 1
            sav(0, gt, True)
        elif psi[0] != 0.0 and has_gprev[0]:
            sav(0, gprev_b, False)
    # ---- penalty frets, eqs. (24b), (55b) ------------------------------------------------------
    frets_j = [padded_interpolant(geo.fret_p[q_], geo.fret_w0[q_], geo.fret_w1[q_], n)
               for q_ in range(len(geo.fret_p))]
    if c.fret_mode == 2:
        pens = np.array([max(geo.fret_m0[q_] - jq @ u0, 0.0) for q_, jq in enumerate(frets_j)])
        if np.any(pens > 0.0):
            vpot = np.sum(c.fret_k / (c.fret_alpha + 1.0) * pens ** (c.fret_alpha + 1.0))
            gt = np.zeros(ni)
            for jq, pq in zip(frets_j, pens, strict=True):
                if pq > 0.0:
                    gt -= c.fret_k * pq ** c.fret_alpha / math.sqrt(2.0 * vpot + EPS) * jq
            gprev_f = gt.copy()
            has_gprev[1] = 1
            sav(1, gt, True)
        elif psi[1] != 0.0 and has_gprev[1]:
            sav(1, gprev_f, False)

    # ---- fingers, eqs. (25)-(27), (55c-d), with contact damping ------------------------------
    for s in range(nslot):
        if f_state[s] != ACTIVE:
            continue
        v = np.concatenate([fj[s], -np.eye(nslot)[s]])  # eta = j.u - w
        eta = v[:ni] @ u0 - f_w[s]
        contact = eta > 0.0
        if contact:
            ea = eta ** c.fg_alpha
            bt = c.fg_k * ea / math.sqrt(2.0 * c.fg_k / (c.fg_alpha + 1.0) * ea * eta + EPS)
            f_bprev[s] = bt
        elif f_psi[s] != 0.0:
            bt = f_bprev[s]
        else:
            continue
        vlv = v @ (lam_z * v)
        g = 1.0 if joint and contact else gamma(
            f_psi[s], bt * (v @ zfree - v @ z1), bt * bt * vlv, contact, rule)
        if bt * g == 0.0 and not contact:
            continue
        chi = 1.0 if contact else 0.0
        r = ctl.fs_r[s] if step >= ctl.fs_rs[s] else c.fg_r
        cols.append(_finger_col(v, bt, g, chi, r / (2.0 * k), f_psi[s], z1, slot=s,
                                contact=contact, vlv=vlv))
    # ---- dampers: x = -R d(v.u) / (2 k) ---------------------------------------------------------
    for d in range(len(ctl.dp_on)):
        if not ctl.dp_on[d] <= step < ctl.dp_off[d]:
            continue
        vd = np.zeros(ni)
        for e in range(ctl.dp_ptr[d], ctl.dp_ptr[d + 1]):
            vd[ctl.dp_idx[e] - 2] += ctl.dp_w[e]
        v = on_string(vd)
        cr = ctl.dp_r[d] / (2.0 * k)
        cols.append(_Col("damper", v, c=cr, alpha=cr * (v @ z1)))

    # ---- the solve, rigid frets by an active set, the joint gamma rule --------------------------
    rigid = c.fret_mode == 1
    active = [q_ for q_ in range(len(frets_j)) if fret_active[q_]] if rigid else []
    x = None
    for gpass in range(2):
        for _ in range(200):
            all_cols = cols + [_Col("rigid" if q_ < geo.nfret else "rigid board",
                                    on_string(frets_j[q_]), m0=geo.fret_m0[q_])
                               for q_ in active]
            x = _solve(all_cols, zfree, lam_z)
            if not rigid:
                break
            xr = x[len(cols):]
            if len(xr) and xr.min() < 0.0:
                active.pop(int(np.argmin(xr)))  # a fret that pulls leaves
                continue
            z = _predict(all_cols, x, zfree, lam_z)
            viol = np.array([jq @ z[:ni] - geo.fret_m0[q_] for q_, jq in enumerate(frets_j)])
            viol[active] = 0.0
            if not len(viol) or viol.min() >= -1e-12:
                break
            active.append(int(np.argmin(viol)))  # the deepest penetrated fret joins
        else:
            raise RuntimeError("the naive active set did not settle")
        if gpass == 1 or not joint:
            break
        if not _joint_gamma(cols, all_cols, x, zfree, z1, lam_z, psi, f_psi):
            break

    # ---- apply: z^(n+1) = z_free + Lambda V x; psi updates, eq. (48) -------------------------
    z = _predict(all_cols, x, zfree, lam_z)
    un = z[:ni]
    # the size of the terms each psi is summed from (its rounding is relative to that): a column's
    # v.z is itself a sum, whose terms (for a finger, the string under it and the finger's own
    # position, each far larger than their difference, the compression) set its rounding
    psi_scale = np.abs(psi)
    f_psi_scale = np.abs(f_psi)
    for col in cols:
        if col.kind == "sav":
            psi[col.which] += 0.5 * (col.v @ z - col.v @ z1)
            psi_scale[col.which] += 0.5 * (np.abs(col.v) @ (np.abs(z) + np.abs(z1)))
        elif col.kind == "finger":
            f_psi[col.slot] += 0.5 * col.beta * (col.v @ z - col.v @ z1)
            f_psi_scale[col.slot] += (0.5 * abs(col.beta)
                                      * (np.abs(col.v) @ (np.abs(z) + np.abs(z1))))
    for s in range(nslot):
        if f_state[s] == ACTIVE:
            f_w1[s] = f_w[s]
            f_w[s] = z[ni + s]
    fa = np.zeros_like(fret_active)
    fa[active] = 1
    out = np.array([padded_interpolant(geo.out_p[i], geo.out_w0[i], geo.out_w1[i], n)
                    @ (un - u0) / k for i in range(len(geo.out_p))])
    return {"u": un, "u1": u0, "psi": psi, "f_state": f_state, "f_w": f_w, "f_w1": f_w1,
            "f_psi": f_psi, "f_bprev": f_bprev, "gprev_b": gprev_b, "fret_active": fa,
            "out": out, "columns": [col.kind for col in all_cols], "psi_scale": psi_scale,
            "f_psi_scale": f_psi_scale}


def _finger_col(v, bt, g, chi, rdamp, psi_f, z1, **extra):
    """The finger's row x = -beta (psi_f + beta d_eta / 4) - chi R d_eta / (2 k), beta = g bt."""
    beta = g * bt
    cf = 0.25 * beta * beta + chi * rdamp
    return _Col("finger", v, c=cf, alpha=-beta * psi_f + cf * (v @ z1), beta=beta, bt=bt,
                gam=g, chi=chi, psi=psi_f, rdamp=rdamp, **extra)


def _joint_gamma(cols, all_cols, x, zfree, z1, lam_z, psi, f_psi) -> bool:
    """Sec. 4.7 on the joint solution: each SAV or finger column's mean psi predicted from the
    solve; where it pulls in contact (or, out of contact, the residual's root moved), gamma from
    the prediction with every other column's force.  Changes the columns in place."""
    changed = False
    for i, col in enumerate(cols):
        if col.kind not in ("sav", "finger"):
            continue
        others = zfree.copy()
        for j, cj in enumerate(all_cols):
            if j != i:
                others += lam_z * cj.v * x[j]
        z = others + lam_z * col.v * x[i]
        if col.kind == "finger":
            ps = f_psi[col.slot]
            mean = ps + 0.25 * col.beta * (col.v @ (z - z1))
            xi = col.bt * (col.v @ (others - z1))
            s_ = col.bt * col.bt * col.vlv
        else:
            ps = psi[col.which]
            mean = -x[i]
            xi = col.gt @ (others - z1)
            s_ = col.s
        if col.contact:
            if mean >= 0.0:
                continue
            gnew = gamma(ps, xi, s_, True)
            if gnew >= col.gam:
                continue
        else:
            gnew = gamma(ps, xi, s_, False)
            if abs(gnew - col.gam) <= 1e-9 * abs(col.gam):
                continue
        changed = True
        if col.kind == "finger":
            cols[i] = _finger_col(col.v, col.bt, gnew, col.chi, col.rdamp, ps, z1, slot=col.slot,
                                  contact=col.contact, vlv=col.vlv)
        else:
            v = col.gt * gnew
            cols[i] = _Col("sav", v, c=0.25, alpha=-ps + 0.25 * (v @ z1), which=col.which,
                           gt=col.gt, gam=gnew, s=col.s, contact=col.contact)
    return changed


# ---- stepping a scene with both --------------------------------------------------------------

# Scenes that between them bring every column and contact into play (``compare_steps`` over
# the stretch where they act).  name: (events, seconds compared from the start, the column kinds
# that must have acted)
CASES = {
    "pluck": ([pluck(6, force=8.0)], 0.004, {"kc"}),
    "fretted": ([fret(3, 5), pluck(3, time=0.003, force=4.0)], 0.008, {"finger", "rigid"}),
    "tap": ([tap(2, 7, velocity=1.0)], 0.006, {"finger", "rigid"}),
    "slam": ([tap(1, 12, force=10.0, velocity=5.0)], 0.004, {"finger", "rigid board"}),
    "slide": ([fret(3, 5), pluck(3, time=0.002, force=4.0),
               {"type": "slide", "time": 0.003, "string": 3, "from_fret": 5, "to_fret": 7,
                "duration": 0.003}], 0.008, {"finger", "rigid"}),
    "harmonic": ([{"type": "harmonic", "time": 0.0, "string": 1, "fret": 12, "release": 0.004},
                  pluck(1, time=0.001, force=2.0)], 0.006, {"damper"}),
    "palm-mute": ([{"type": "mute", "time": 0.0, "string": 6}, pluck(6, time=0.001, force=4.0)],
                  0.004, {"damper"}),
    "bend": ([fret(2, 7), pluck(2, time=0.001, force=4.0),
              {"type": "bend", "time": 0.002, "string": 2, "semitones": 1.0, "duration": 0.003}],
             0.006, {"finger", "rigid"}),
}



STATE_FIELDS = ("u", "psi", "f_w", "f_psi")


def compare_steps(scene: dict, seconds: float, options=None, start: float = 0.0) -> dict:
    """Step every voice of ``scene`` one internal step at a time through ``kernels.step_block``
    and, on the same state in, through ``naive_step``; returns, over the steps from ``start`` to
    ``start + seconds`` of scene time, the largest relative difference of each state field
    (u^(n+1) over max |u^(n+1)|, the pickups' velocity over max |u^(n+1) - u^n| / k, the fingers'
    w over max |w|, each psi over the size of the terms it is summed from, eq. (48)), the number
    of steps in which the two differ in a discrete decision (a finger's state, the rigid frets'
    active set), the steps compared and how many steps had each kind of column.  The kernel's
    state goes on to the next step, so differences do not accumulate."""
    from engine import RenderOptions, Scene
    from engine.fd import kernels
    from engine.fd.instrument import prepare

    sc = Scene.model_validate(scene)
    g = prepare(sc, options or RenderOptions())
    worst = {f: 0.0 for f in (*STATE_FIELDS, "out")}
    decisions = 0
    kinds: dict[str, int] = {}
    compared = 0
    for v in g.voices:
        c, geo, ctl, st = v.coefs, v.geom, v.ctl.arrays, v.state
        rate = sc.sample_rate * v.oversample
        first, last = round(start * rate), round((start + seconds) * rate)
        npk = len(geo.out_p)
        step_fn = None
        for step in range(last):
            st_in = kernels.State(*[a.copy() for a in st])
            out = np.zeros((npk, 1))
            args = (c, geo, ctl, st, v.policy, step, 1, out, False, np.empty(0), np.empty(0),
                    np.empty(0))
            step_fn = step_fn or kernels.entry_point(kernels.step_block, args)
            if step_fn(*args) != kernels.OK:
                raise FloatingPointError("the kernel's step became non-finite")
            if step < first:
                continue
            ref = naive_step(c, geo, ctl, st_in, step)
            compared += 1
            for kd in set(ref["columns"]):
                kinds[kd] = kinds.get(kd, 0) + 1
            n = c.n
            un = st.u[2:n + 1]
            scale = {"u": np.max(np.abs(un)), "out": np.max(np.abs(un - st_in.u[2:n + 1])) / c.k,
                     "f_w": np.max(np.abs(st.f_w), initial=0.0),
                     # psi^(n+1/2) = psi^(n-1/2) + (v.z^(n+1) - v.z^(n-1)) / 2 cancels (to zero
                     # out of contact): its scale is that of the terms it is summed from
                     "psi": np.max(ref["psi_scale"]),
                     "f_psi": np.max(ref["f_psi_scale"], initial=0.0)}
            got = {"u": un, "psi": st.psi, "f_w": st.f_w, "f_psi": st.f_psi, "out": out[:, 0]}
            for f in worst:
                d = np.max(np.abs(got[f] - ref[f]), initial=0.0)
                if d > 0.0:
                    worst[f] = max(worst[f], d / scale[f] if scale[f] > 0.0 else math.inf)
            if (not np.array_equal(st.f_state, ref["f_state"])
                    or not np.array_equal(st.fret_active, ref["fret_active"])):
                decisions += 1
    return {"worst": worst, "decisions": decisions, "steps": compared, "kinds": kinds}


def main() -> None:
    """Print ``compare_steps`` on each of ``CASES`` (what ``test_naive_step.py`` asserts)."""
    print("| scene | steps | u | pickup velocity | psi | finger w | finger psi | decisions differ |")
    print("| --- | --- | --- | --- | --- | --- | --- | --- |")
    for name, (events, seconds, _) in CASES.items():
        r = compare_steps(scene(events, seconds), seconds)
        w = r["worst"]
        print(f"| {name} | {r['steps']} | {w['u']:.1e} | {w['out']:.1e} | {w['psi']:.1e} | "
              f"{w['f_w']:.1e} | {w['f_psi']:.1e} | {r['decisions']} |", flush=True)


if __name__ == "__main__":
    main()
