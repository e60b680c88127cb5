"""The time-step loop of one string, ``step_block``: the general path of the step described in
``engine.fd.kernels`` (assemble the active columns, solve for their multipliers, update, book the
energy), with the quiet and held runs of ``engine.fd.kernels.runs`` taken wherever they apply.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ...config import JIT, JIT_STEP
from .collisions import _add_rigid, _borrowed, _fret_hit, _remove_col, _sav_board, _sav_frets
from .data import (
    ACTIVE,
    BOARD,
    DAMPER,
    FINGER,
    FRETPEN,
    GAMMA_JOINT,
    GONE,
    IDLE,
    KC,
    NONFINITE,
    OK,
    RIGID,
    Work,
)
from .energy import _step_energy
from .excitation import _pluck_forces
from .finger import _beta, _eta, _finger_row, _finger_x, _w_free
from .linear import (
    _add_kc,
    _bent_stencil,
    _counted,
    _ends,
    _kc_multiplier,
    _pass,
    _pass_kc,
    _pickups,
    interp,
)
from .runs import _held_run, _held_until, _quiet_run, _quiet_until
from .sav import _gamma, _joint_gamma
from .system import _assemble, _gram, _ray_blocked, _scatter, _solve, _step_to_zero, _unscatter


@njit(**JIT)
def step_block(c, geo, ctl, st, pol, step0, nsteps, out, diag, e_h, e_q, e_p):
    """Advance one string by ``nsteps`` steps from global step ``step0``.

    Fills ``out[pickup, step]`` (string velocity at each pickup, m/s) and, when ``diag``, the
    energy series e_h = H^(n+1/2), e_q = k Q^n and e_p = k P^n, where P also carries the energy a
    finger brings or takes away when it is put down or removed and the work of a changing tension.
    Returns a status code.  ``st`` holds u^n, u^(n-1) and the contact state on entry and on exit;
    ``pol`` (``Policy``) says whether quiet and held steps may take their own loops.
    Allocates the block's scratch (``Work``) and hands over to ``_advance``.
    """
    n = c.n
    nfret = geo.fret_p.shape[0]
    nslot = ctl.fs_on.shape[0]
    ncap = 3 + nslot + nfret + ctl.dp_on.shape[0]
    cap = 2 * (n + 3) + 4 * nfret + 4 * nslot + ctl.dp_idx.shape[0] + 8
    w = Work(
        kind=np.empty(ncap, np.int64), cstart=np.empty(ncap + 1, np.int64),
        cslot=np.empty(ncap, np.int64), cfret=np.empty(ncap, np.int64), ca=np.empty(ncap),
        cc=np.empty(ncap), vfree=np.empty(ncap), v1=np.empty(ncap),
        cidx=np.empty(cap, np.uint64), cval=np.empty(cap), g=np.empty((ncap, ncap)),
        a=np.empty((ncap, ncap)), x=np.empty(ncap), xp=np.empty(ncap), cgam=np.empty(ncap),
        cs=np.empty(ncap), cbt=np.empty(ncap), ccon=np.zeros(ncap, np.bool_),
        scr=np.zeros(n + 3), du=np.zeros(n + 3), wfree=np.empty(nslot), fext=np.zeros(nslot),
        fp=np.zeros(nslot, np.int64), fw0=np.zeros(nslot), fw1=np.zeros(nslot),
        fchi=np.zeros(nslot), fr=np.zeros(nslot), fbeta=np.zeros(nslot),
        fcol=np.full(nslot, -1, np.int64),
        rd=np.empty(ncap), ra=np.empty((ncap, ncap)))
    return _advance(c, geo, ctl, st, pol, w, step0, nsteps, out, diag, e_h, e_q, e_p)


@njit(**JIT_STEP)
def _advance(c, geo, ctl, st, pol, w, step0, nsteps, out, diag, e_h, e_q, e_p):
    """``step_block``'s loop (the general path, which hands quiet and held steps to their runs),
    on the scratch ``w`` that step_block allocated; returns the status."""
    U0, U1, UF, Q = st.u, st.u1, st.uf, st.q
    psi, gprev_b, gprev_f, has_gprev = st.psi, st.gprev_b, st.gprev_f, st.has_gprev
    fret_active, f_state, f_w, f_w1, f_psi, f_bprev = (
        st.fret_active, st.f_state, st.f_w, st.f_w1, st.f_psi, st.f_bprev)
    board, bnear, near, count = geo.board, geo.bnear, geo.near, _counted(c, geo)
    b2, c0, c1, ih2 = c.b2, c.c0, c.c1, c.ih2
    fret_p, fret_w0, fret_w1, fret_m0 = geo.fret_p, geo.fret_w0, geo.fret_w1, geo.fret_m0
    pl_start, pl_len, pl_amp, pl_p, pl_w0, pl_w1 = (
        ctl.pl_start, ctl.pl_len, ctl.pl_amp, ctl.pl_p, ctl.pl_w0, ctl.pl_w1)
    fs_on, fs_rel, fs_x0, fs_x1, fs_ms, fs_me, fs_force, fs_v0, fs_gap, fs_r, fs_rs = (
        ctl.fs_on, ctl.fs_rel, ctl.fs_x0, ctl.fs_x1, ctl.fs_ms, ctl.fs_me, ctl.fs_force,
        ctl.fs_v0, ctl.fs_gap, ctl.fs_r, ctl.fs_rs)
    ndamp = ctl.dp_on.shape[0]
    npk = geo.out_p.shape[0]
    n = c.n
    k = c.k
    lam = c.lam
    nfret = fret_p.shape[0]
    nslot = fs_on.shape[0]
    kind, cstart, cslot, cfret, ca, cc, vfree, v1 = (
        w.kind, w.cstart, w.cslot, w.cfret, w.ca, w.cc, w.vfree, w.v1)
    cidx, cval, G, A, x, xp, cgam, cs, cbt, ccon = (
        w.cidx, w.cval, w.g, w.a, w.x, w.xp, w.cgam, w.cs, w.cbt, w.ccon)
    scr, du, wfree, fext, fp, fw0, fw1, fchi, fr, fbeta, fcol = (
        w.scr, w.du, w.wfree, w.fext, w.fp, w.fw0, w.fw1, w.fchi, w.fr, w.fbeta, w.fcol)
    lam_f = k * k / c.fg_mass
    status = OK

    b0 = c.b0
    b1 = c.b1
    ratio = 1.0
    # The gradient correction (sec. 4.7) is decided on the joint solution: contact columns enter
    # the first solve with gamma = 1 and ``_joint_gamma`` corrects those whose predicted psi would
    # pull (or stay out of contact).  Alone, a column gets the per-column rule's gamma (up to
    # rounding: a rattling string is sensitive enough that the two paths part after a few hundred
    # samples); together, the prediction includes the others.
    joint = c.gamma_rule == GAMMA_JOINT
    # Quiet steps (nothing but the string's own forces act, ``_quiet_until``, and no contact
    # happens, ``_quiet_run`` checks each step) run in ``_quiet_run``: the linear update, the
    # Kirchhoff-Carrier column, the pickups, the same operations as the general path, so the
    # samples are identical (``Policy.quiet`` False, from ``skip_contacts=False``, never takes it;
    # test_skips.py compares).  With diagnostics every step takes the general path.
    out_p, out_w0, out_w1 = geo.out_p, geo.out_w0, geo.out_w1
    tb_step, tb_ratio = ctl.tb_step, ctl.tb_ratio
    quiet_end = -1  # steps before this may be quiet (what acts on the string allows it)
    stale = not diag  # quiet_end is recomputed, after a general step, only if no contact acted
    s_last = st.s_last[0]  # S of the previous step's u^n
    free = pol.quiet and st.s_last[1] != 0.0  # no contact acted in the last step (a guess)
    held = pol.held and st.s_last[2] != 0.0  # the next step may be held (``_held_run``)
    it = 0
    while it < nsteps:
        step = step0 + it
        if stale and free:
            quiet_end = _quiet_until(step, ctl, st)
            stale = False
        if step < quiet_end and free:
            it_end = min(nsteps, quiet_end - step0)
            done, s_last = _quiet_run(c, geo, ctl, st, w, U0, U1, UF, out, it, it_end, step0,
                                      s_last)
            for _r in range(done % 3):  # the run rotated its own copies of the three arrays
                U0, U1, UF = UF, U0, U1  # u^(n-1) <- u^n <- u^(n+1)
            it += done
            st.run_steps[0] += done
            free = it == it_end  # a run ends early only on a step with a contact
            continue  # that step takes the general path
        if held:
            held = False  # the step after a held run takes the general path...
            held_end, hs = _held_until(step, ctl, st)
            if step < held_end:
                if fp[hs] == 0:  # a block that starts held: the interpolant the finger had
                    fp[hs], fw0[hs], fw1[hs] = interp(
                        _finger_x(fs_x0[hs], fs_x1[hs], fs_ms[hs], fs_me[hs], step), c.h, n)
                it_end = min(nsteps, held_end - step0)
                done, s_last = _held_run(c, geo, ctl, st, w, hs, U0, U1, UF, out, it, it_end,
                                         step0, s_last, diag, e_h, e_q, e_p)
                for _r in range(done % 3):  # the run rotated its own copies
                    U0, U1, UF = UF, U0, U1
                # ...unless the run stopped only because the block ends: the next block goes on
                # with it, so that block boundaries do not change which path a step takes
                held = it + done == nsteps and held_end > step0 + nsteps
                it += done
                st.run_steps[1] += done
                if done > 0:
                    continue
        # ---- a) linear update (+ KC vector, + S and the counts of nodes near a contact) ------
        _ends(U0, n)
        if tb_step.shape[0] > 0:  # a bend: the stencil under this step's tension
            ratio, b0, b1 = _bent_stencil(c, tb_step, tb_ratio, step)
        qq = quf = qu1 = 0.0
        if c.kc > 0.0:
            qq, quf, qu1, s_last, below, close = _pass_kc(n, b0, b1, b2, c0, c1, ih2, U0, U1, UF,
                                                          Q, bnear, near, count)
        else:
            s_last, below, close = _pass(n, b0, b1, b2, c0, c1, ih2, U0, U1, UF, bnear, near,
                                         count)
        # ``below``: nodes below the Hertzian board (contact), or within reach of the rigid one
        hertz = c.board_k > 0.0
        # ---- b) excitation, eq. (5) ------------------------------------------------------------
        pin = 0.0  # k P^n of the plucks is formed after the update: keep the forces
        quf = _pluck_forces(c, step, UF, Q, quf, pl_start, pl_len, pl_amp, pl_p, pl_w0, pl_w1)
        # ---- fingers: life cycle, free update, eq. (39) -------------------------------------
        inject = 0.0
        for s in range(nslot):
            if f_state[s] == IDLE and step >= fs_on[s]:
                f_state[s] = ACTIVE
                p_, a0, a1 = interp(_finger_x(fs_x0[s], fs_x1[s], fs_ms[s], fs_me[s], step), c.h, n)
                f_w[s] = a0 * U0[p_] + a1 * U0[p_ + 1] + fs_gap[s]
                f_w1[s] = f_w[s] + fs_v0[s] * k  # moving towards the board at v0
                f_psi[s] = 0.0
                f_bprev[s] = 0.0
                inject += 0.5 * c.fg_mass * fs_v0[s] * fs_v0[s]
            if f_state[s] != ACTIVE:
                continue
            if fp[s] == 0 or fs_x0[s] != fs_x1[s]:  # a static finger's interpolant is kept
                xs = _finger_x(fs_x0[s], fs_x1[s], fs_ms[s], fs_me[s], step)
                fp[s], fw0[s], fw1[s] = interp(xs, c.h, n)
            p_ = fp[s]
            eta = _eta(fw0[s], fw1[s], p_, U0, f_w[s])
            if step >= fs_rel[s]:
                if -eta > c.fg_lift and f_w[s] > f_w1[s]:
                    # far above the string and rising: the finger leaves the model, and its
                    # energy (kinetic, and any residual psi) leaves the balance as work done
                    vel = (f_w[s] - f_w1[s]) / k
                    inject -= 0.5 * c.fg_mass * vel * vel + 0.5 * f_psi[s] * f_psi[s]
                    f_state[s] = GONE
                    continue
                fext[s] = fs_force[s]  # lifting
            else:
                fext[s] = -fs_force[s]  # pressing towards the board
            fr[s] = fs_r[s] if step >= fs_rs[s] else c.fg_r  # landing: the preset's damping
            wfree[s] = _w_free(f_w[s], f_w1[s], lam_f, fext[s])
        # ---- assemble the columns --------------------------------------------------------------
        nc = 0
        nent = 0
        nsav = 0  # SAV and finger columns: the ones ``_joint_gamma`` looks at
        cstart[0] = 0
        if c.kc > 0.0:
            kind[nc] = KC
            cslot[nc] = -1
            ca[nc] = c.kc * qu1
            cc[nc] = c.kc
            vfree[nc] = quf
            v1[nc] = qu1
            nc += 1
            cstart[nc] = nent
        # c) fretboard, eq. (24a), (55a)
        if hertz and (below > 0 or psi[0] != 0.0):
            nent, used, cgam[nc], cs[nc] = _sav_board(c, U0, U1, UF, board, psi, gprev_b,
                                                      has_gprev, below > 0, joint, cidx, cval,
                                                      nent, scr)
            if used:
                kind[nc] = BOARD
                cslot[nc] = -1
                ccon[nc] = below > 0
                nc += 1
                nsav += 1
                cstart[nc] = nent
        # d) frets as penalty, eq. (24b), (55b)
        if c.fret_mode == 2:
            nent, used, cgam[nc], cs[nc], fcon = _sav_frets(
                c, U0, U1, UF, psi, gprev_f, has_gprev, fret_p, fret_w0, fret_w1, fret_m0,
                joint, cidx, cval, nent, scr)
            if used:
                kind[nc] = FRETPEN
                cslot[nc] = -1
                ccon[nc] = fcon
                nc += 1
                nsav += 1
                cstart[nc] = nent
        # e) fingers, eqs. (25)-(27), (55c-d), with contact damping
        for s in range(nslot):
            fcol[s] = -1
            if f_state[s] != ACTIVE:
                continue
            p_ = fp[s]
            eta = _eta(fw0[s], fw1[s], p_, U0, f_w[s])
            eta1 = _eta(fw0[s], fw1[s], p_, U1, f_w1[s])
            etaf = _eta(fw0[s], fw1[s], p_, UF, wfree[s])
            contact = eta > 0.0
            if contact:
                bt = _beta(c, eta)
                f_bprev[s] = bt
            elif f_psi[s] != 0.0:
                bt = f_bprev[s]
            else:
                continue
            vlv = lam * (fw0[s] * fw0[s] + fw1[s] * fw1[s]) + lam_f
            cbt[nc] = bt
            cs[nc] = bt * bt * vlv
            if joint and contact:
                gm = 1.0
            else:
                gm = _gamma(f_psi[s], bt * (etaf - eta1), bt * bt * vlv, contact, c.gamma_rule)
            cgam[nc] = gm
            ccon[nc] = contact
            bt *= gm
            if bt == 0.0 and not contact:
                continue
            fbeta[s] = bt
            fchi[s] = 1.0 if contact else 0.0
            cc[nc], ca[nc] = _finger_row(bt, f_psi[s], eta1, fchi[s], fr[s] / (2.0 * k))
            kind[nc] = FINGER
            cslot[nc] = s
            vfree[nc] = etaf
            v1[nc] = eta1
            cidx[nent] = p_
            cval[nent] = fw0[s]
            cidx[nent + 1] = p_ + 1
            cval[nent + 1] = fw1[s]
            nent += 2
            fcol[s] = nc
            nc += 1
            nsav += 1
            cstart[nc] = nent
        # dampers: a light touch or a palm, f = -R d/dt (v^T u) (bilateral, lossy), counted in Q
        for d in range(ndamp):
            if step < ctl.dp_on[d] or step >= ctl.dp_off[d]:
                continue
            cr = ctl.dp_r[d] / (2.0 * k)
            sf = 0.0
            s1 = 0.0
            for e in range(ctl.dp_ptr[d], ctl.dp_ptr[d + 1]):
                pi_ = ctl.dp_idx[e]
                cidx[nent] = pi_
                cval[nent] = ctl.dp_w[e]
                sf += ctl.dp_w[e] * UF[pi_]
                s1 += ctl.dp_w[e] * U1[pi_]
                nent += 1
            kind[nc] = DAMPER
            cslot[nc] = -1
            ca[nc] = -cr * s1
            cc[nc] = cr
            vfree[nc] = sf
            v1[nc] = s1
            nc += 1
            cstart[nc] = nent
        # SAV columns' row data (board / penalty frets): x + 1/4 g.z^(n+1) = -(psi - 1/4 g.z^(n-1))
        for ci in range(nc):
            if kind[ci] == BOARD or kind[ci] == FRETPEN:
                sf = 0.0
                s1 = 0.0
                for e in range(cstart[ci], cstart[ci + 1]):
                    sf += cval[e] * UF[cidx[e]]
                    s1 += cval[e] * U1[cidx[e]]
                ps = psi[0] if kind[ci] == BOARD else psi[1]
                ca[ci] = ps - 0.25 * s1
                cc[ci] = 0.25
                vfree[ci] = sf
                v1[ci] = s1
        nbase = nc
        # ---- f) solve; rigid frets by a warm-started active set -------------------------------
        # Rigid frets are looked at only when one can be reached this step: some node of u^n is
        # within the margin of a fret tip (``near``) or of a rigid board (``bnear``), a rigid
        # constraint is active, or a finger touches.
        rigid = c.fret_mode == 1 and (close > 0 or nc > (1 if c.kc > 0.0 else 0)
                                      or (below > 0 and not hertz))
        if rigid:
            for q in range(nfret):
                if fret_active[q]:
                    nent = _add_rigid(q, nc, kind, cslot, cfret, cstart, cidx, cval, nent,
                                      fret_p, fret_w0, fret_w1, fret_m0, UF, U1, ca, vfree, v1)
                    nc += 1
        for gpass in range(2):
            # The rigid frets' reactions x_r >= 0 solve a convex QP in the multipliers (the
            # system, each non-rigid row scaled by 1/c, is symmetric positive semidefinite) whose
            # gradient in x_r is the fret's gap.  The sign rule alone (drop the most negative
            # reaction, add the deepest penetration) cycled on crowded frets, whose constraints
            # are (nearly) linearly dependent.  So once a solve has left every reaction >= 0
            # (``feasible``; kept in ``xp`` when a fret is added), the loop is Lawson and Hanson's
            # active-set method, which ends after finitely many changes: a fret that joins does
            # so only as far as no other reaction turns negative on the way (``_ray_blocked``),
            # and a later solve with a negative reaction is taken only as far as the first one
            # reaches zero (``_step_to_zero``); that fret leaves.  Every pass ends in a solve of
            # the current column set, so the multipliers applied below belong to the columns
            # applied with them (the discrete energy balance depends on it); the 2 M + 4 changes
            # allowed are a guard.
            changes = 0
            feasible = False
            while True:
                if nc == 1 and kind[0] == KC:
                    x[0] = _kc_multiplier(c, qq, quf, qu1)
                elif nc > 0:
                    _gram(nc, kind, cstart, cidx, cval, cslot, Q, qq, lam, lam_f, G, scr)
                    _assemble(nc, kind, ca, cc, vfree, G, A, x)
                    if not _solve(A, x, nc):
                        if nc > nbase:  # drop the newest rigid constraint and try again
                            fret_active[cfret[nc - 1]] = 0
                            nc -= 1
                            nent = cstart[nc]
                            continue
                        status = NONFINITE
                        break
                if not rigid or changes == 2 * nfret + 4:
                    break
                changes += 1
                # a negative reaction: the fret leaves (see above for which one)
                worst = -1
                wval = 0.0
                for i in range(nbase, nc):
                    if x[i] < wval:
                        wval = x[i]
                        worst = i
                if worst >= 0 and feasible:
                    worst = _step_to_zero(x, xp, nbase, nc)
                if worst >= 0:
                    fret_active[cfret[worst]] = 0
                    nc = _remove_col(worst, nc, kind, cslot, cfret, cstart, cidx, cval, ca, cc,
                                     vfree, v1, xp)
                    nent = cstart[nc]
                    continue
                # every reaction >= 0: add the fret the prediction penetrates deepest, if any
                xk = _scatter(nc, kind, cstart, cidx, cval, x, lam, du)
                add = _fret_hit(c.kc > 0.0, True, below > 0, _borrowed(UF), _borrowed(du),
                                _borrowed(Q), _borrowed(fret_p), _borrowed(fret_w0),
                                _borrowed(fret_w1), _borrowed(fret_m0), _borrowed(fret_active),
                                geo.nfret, lam * xk)
                _unscatter(nc, cstart, cidx, du)
                if add < 0:
                    break
                for i in range(nc):
                    xp[i] = x[i]
                xp[nc] = 0.0
                feasible = True
                fret_active[add] = 1
                nent = _add_rigid(add, nc, kind, cslot, cfret, cstart, cidx, cval, nent, fret_p,
                                  fret_w0, fret_w1, fret_m0, UF, U1, ca, vfree, v1)
                nc += 1
                blk = _ray_blocked(nc, nbase, kind, cstart, cidx, cval, cslot, Q, qq, lam, lam_f,
                                   ca, cc, vfree, xp, G, A, x, scr, w.rd, w.ra)
                if blk >= 0:
                    # the way to the new fret's constraint meets a zero reaction first (or the
                    # new fret depends on the others): that fret leaves, xp moved on
                    changes += 1
                    fret_active[cfret[blk]] = 0
                    nc = _remove_col(blk, nc, kind, cslot, cfret, cstart, cidx, cval, ca, cc,
                                     vfree, v1, xp)
                    nent = cstart[nc]
            # gamma of the contact columns from the joint solution, sec. 4.7 (one correction at
            # most: a second solve, never an iteration)
            if gpass == 1 or not joint or nsav == 0 or status != OK:
                break
            if not _joint_gamma(nbase, kind, cslot, cstart, cval, ca, cc, vfree, v1, x, G, cgam,
                                cs, cbt, ccon, psi, f_psi, fbeta, fchi, fr, k, nc):
                break
        # no contact acted (the Kirchhoff-Carrier column at most): the next step may be quiet
        free = pol.quiet and not (hertz and below > 0) and nc == (1 if c.kc > 0.0 else 0)
        # a finger in contact held the string, alone or with rigid frets: the next step may be held
        nk = 1 if c.kc > 0.0 else 0
        held = (pol.held and joint and c.fret_mode != 2 and status == OK
                and nbase == nk + 1 and kind[nk] == FINGER and ccon[nk])
        # ---- apply the multipliers: z^(n+1) = z_free + Lambda sum_c v_c x_c ----------------------
        xk = _scatter(nc, kind, cstart, cidx, cval, x, lam, UF)
        if xk != 0.0:
            _add_kc(n, UF, Q, lam * xk)
        # fingers' new positions and psi updates, eqs. (41), (48)
        qloss = 0.0
        for s in range(nslot):
            if f_state[s] != ACTIVE:
                continue
            wn = wfree[s]
            ci = fcol[s]
            if ci >= 0:
                wn -= lam_f * x[ci]
            p_ = fp[s]
            etan = _eta(fw0[s], fw1[s], p_, UF, wn)
            if ci >= 0:
                deta = etan - v1[ci]
                f_psi[s] += 0.5 * fbeta[s] * deta
                if diag:
                    dr = deta / (2.0 * k)
                    qloss += fchi[s] * fr[s] * dr * dr * k
            if diag:
                pin += fext[s] * (wn - f_w1[s]) * 0.5
            f_w1[s] = f_w[s]
            f_w[s] = wn
        for ci in range(nc):
            kd = kind[ci]
            if kd == BOARD or kd == FRETPEN:
                sn = 0.0
                for e in range(cstart[ci], cstart[ci + 1]):
                    sn += cval[e] * UF[cidx[e]]
                psi[kd - 1] += 0.5 * (sn - v1[ci])
            elif kd == DAMPER and diag:
                sn = 0.0
                for e in range(cstart[ci], cstart[ci + 1]):
                    sn += cval[e] * UF[cidx[e]]
                qloss -= x[ci] * (sn - v1[ci]) * 0.5  # = R (D. v^T u)^2 k
            elif kd == RIGID and diag:
                p_ = fret_p[cfret[ci]]
                sn = fret_w0[cfret[ci]] * UF[p_] + fret_w1[cfret[ci]] * UF[p_ + 1]
                qloss -= x[ci] * (sn - v1[ci]) * 0.5  # reaction's work, booked as loss
        # ---- output: velocity at the pickup ---------------------------------------------------
        _pickups(out_p, out_w0, out_w1, UF, U0, k, out, it)
        if diag:
            _step_energy(c, ratio, step, step0, it, UF, U0, U1, psi, f_state, f_psi, f_w, f_w1,
                         pl_start, pl_len, pl_amp, pl_p, pl_w0, pl_w1, pin, inject, qloss,
                         st.tens, e_h, e_q, e_p)
        # ---- rotate: u^(n-1) <- u^n <- u^(n+1) ----------------------------------------------------
        U0, U1, UF = UF, U0, U1  # u^(n-1) <- u^n <- u^(n+1)
        stale = not diag  # what acts on the string may have changed
        it += 1
    st.s_last[0] = s_last
    st.s_last[1] = 1.0 if free else 0.0
    st.s_last[2] = 1.0 if held else 0.0
    # hand the state back in the caller's arrays (U0/U1 may have rotated)
    if nsteps % 3 != 0:
        _restore(U0, U1, UF, nsteps % 3)
    for it in range(nsteps):
        if npk > 0 and not math.isfinite(out[0, it]):
            status = NONFINITE
            break
    return status


@njit(**JIT)
def _restore(U0, U1, UF, r):
    """After r (1 or 2) rotations, the caller's (u, u1, uf) hold (u^n, ...) in a rotated order."""
    # the caller's arrays, in order (a, b, c), started as (u^n, u^(n-1), scratch).  After one
    # rotation the local U0 is the caller's c, U1 the caller's a; after two, U0 = b, U1 = c.
    # node by node, in place
    if r == 1:
        # local (U0, U1, UF) = (c, a, b): caller wants a <- u^n (=c), b <- u^(n-1) (=a)
        for j in range(U0.shape[0]):
            UF[j] = U1[j]  # b <- a
            U1[j] = U0[j]  # a <- c
    else:
        # local (U0, U1, UF) = (b, c, a): caller wants a <- u^n (=b), b <- u^(n-1) (=c)
        for j in range(U0.shape[0]):
            UF[j] = U0[j]  # a <- b
            U0[j] = U1[j]  # b <- c
