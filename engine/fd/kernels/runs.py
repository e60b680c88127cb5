"""Steps that do the general path's arithmetic without its bookkeeping: quiet steps, in which nothing
but the string's own forces acts, and the held steps of a fretted note, in which the forces that
act do not change (docs/engine.md, "Skips").  Each run checks, in every step, every decision
the general path would take, and returns at the first step on which one differs; compiled as the
general path is and calling the same linear pass, it gives its samples to the last bit
(``tests/engine/test_held.py``, ``tests/engine/test_skips.py``).
"""

from __future__ import annotations

from numba import njit

from ...config import JIT, JIT_STEP
from .collisions import _add_rigid, _borrowed, _contact, _fret_hit, _rigid_row
from .data import ACTIVE, FINGER, IDLE, KC
from .energy import _step_energy
from .excitation import _pluck_forces
from .finger import _beta, _eta, _finger_row, _w_free
from .linear import (
    _add_kc,
    _bent_stencil,
    _counted,
    _ends,
    _kc_multiplier,
    _pass,
    _pass_kc,
    _pickups,
)
from .sav import _joint_gamma
from .system import _assemble, _gram, _gram_kc, _scatter, _solve, _unscatter


@njit(**JIT)
def _quiet_until(s, ctl, st):
    """The first step >= s at which a quiet step is not allowed (s itself if step s is not quiet).

    A step may be quiet when nothing acts on the string but its own forces: no pluck force, no
    finger on the string or about to be put down, no damper, no residual psi of a contact, no
    rigid constraint in the active set.  If no contact happens either (``_quiet_run`` checks each step),
    the step is the linear update plus the Kirchhoff-Carrier column, and ``_quiet_run`` takes it.
    Nothing of this changes in a quiet step, so the answer holds until the next general step.
    """
    psi, f_state, fret_active = st.psi, st.f_state, st.fret_active
    pl_start, pl_len, fs_on = ctl.pl_start, ctl.pl_len, ctl.fs_on
    dp_on, dp_off = ctl.dp_on, ctl.dp_off
    if psi[0] != 0.0 or psi[1] != 0.0:
        return s
    for q in range(fret_active.shape[0]):
        if fret_active[q]:
            return s
    end = 1 << 62
    for e in range(pl_start.shape[0]):
        a = pl_start[e]
        if a <= s <= a + pl_len[e]:
            return s
        if a > s and a < end:
            end = a
    for q in range(f_state.shape[0]):
        if f_state[q] == ACTIVE:
            return s
        if f_state[q] == IDLE:
            if fs_on[q] <= s:
                return s
            if fs_on[q] < end:
                end = fs_on[q]
    for d in range(dp_on.shape[0]):
        if dp_on[d] <= s < dp_off[d]:
            return s
        if dp_on[d] > s and dp_on[d] < end:
            end = dp_on[d]
    return end


@njit(**JIT_STEP)
def _quiet_run(c, geo, ctl, st, w, U0, U1, UF, out, it, it_end, step0, s_last):
    """Quiet steps it, it + 1, ... (< it_end) while no contact happens, on u^n = U0, u^(n-1) = U1
    and the scratch UF (the caller's rotation of ``st``'s three arrays); returns (steps done, S of
    the last u^n looked at).

    The caller guarantees that nothing but the string's own forces acts before it_end
    (``_quiet_until``; so no rigid fret is active, and ``du`` is zero).  A step is then the linear
    update, the Kirchhoff-Carrier column (left out while S of u^(n-1) is below
    ``Coefs.kc_s_skip``) and the pickups, the same operations, on the same helpers compiled the
    same way (``config.JIT_STEP``), as ``step_block``'s general path, provided no contact acts:
    no node of u^n is below a Hertzian fretboard, and either none is within reach of a fret tip
    or of a rigid board (the counts of ``_pass_kc``) or (rigid frets) ``_fret_hit`` finds no
    fret and no node of the board penetrated by u^(n+1): the general path would look at them,
    find none to add and keep the Kirchhoff-Carrier column alone.
    The first step with a contact is not taken (its u_free is scratch) and goes to the general
    path.  A loop of its own: as a branch of ``step_block``'s loop the same step was slower (the
    general path's many variables crowd the loop).
    """
    Q, fret_active, du = st.q, st.fret_active, w.du
    fret_p, fret_w0, fret_w1, fret_m0 = geo.fret_p, geo.fret_w0, geo.fret_w1, geo.fret_m0
    out_p, out_w0, out_w1 = geo.out_p, geo.out_w0, geo.out_w1
    tb_step, tb_ratio = ctl.tb_step, ctl.tb_ratio
    bnear, near, count = geo.bnear, geo.near, _counted(c, geo)
    b2, c0, c1, ih2 = c.b2, c.c0, c.c1, c.ih2
    n = c.n
    b0 = c.b0
    b1 = c.b1
    lam = c.lam
    ratio = 1.0
    done = 0
    for i in range(it, it_end):
        with_kc = c.kc > 0.0 and s_last >= c.kc_s_skip
        _ends(U0, n)
        if tb_step.shape[0] > 0:  # a bend: the stencil under this step's tension
            ratio, b0, b1 = _bent_stencil(c, tb_step, tb_ratio, step0 + i)
        qq = quf = qu1 = 0.0
        if with_kc:
            qq, quf, qu1, s, below, close = _pass_kc(n, b0, b1, b2, c0, c1, ih2, U0, U1, UF, Q,
                                                     bnear, near, count)
        else:
            s, below, close = _pass(n, b0, b1, b2, c0, c1, ih2, U0, U1, UF, bnear, near, count)
        xk = _kc_multiplier(c, qq, quf, qu1) if with_kc else 0.0
        if (below > 0 or close > 0) and _contact(c, below, close, UF, du, Q, fret_p, fret_w0,
                                                 fret_w1, fret_m0, fret_active, geo.nfret,
                                                 lam * xk):
            return done, s
        s_last = s
        if xk != 0.0:
            _add_kc(n, UF, Q, lam * xk)
        _pickups(out_p, out_w0, out_w1, UF, U0, c.k, out, i)
        U0, U1, UF = UF, U0, U1  # u^(n-1) <- u^n <- u^(n+1)
        done += 1
    return done, s_last


@njit(**JIT)
def _held_until(s, ctl, st):
    """The first step >= s at which a held step is not allowed, and the finger slot that holds the
    string; (s, -1) if step s may not be held.

    A held step is a general step of a fixed kind (see ``_held_run``): one finger on the string,
    staying where it is and pressing with one damping (it changes once the finger has landed,
    ``Controls.fs_rs``), no other finger put down or lifted, no damper, no residual
    psi of the fretboard or the penalty frets.  Plucks may act (their forces are added as in the
    general path).  A sliding finger holds before its slide begins and after it ends: its
    interpolant, worked out in the general step before the run, is the one each step would get.
    Nothing of this changes in a held step, so the answer holds until the next general step.
    """
    psi, f_state = st.psi, st.f_state
    fs_on, fs_rel, fs_x0, fs_x1, fs_ms, fs_me, fs_rs = (
        ctl.fs_on, ctl.fs_rel, ctl.fs_x0, ctl.fs_x1, ctl.fs_ms, ctl.fs_me, ctl.fs_rs)
    dp_on, dp_off = ctl.dp_on, ctl.dp_off
    if psi[0] != 0.0 or psi[1] != 0.0:
        return s, -1
    end = 1 << 62
    slot = -1
    for q in range(f_state.shape[0]):
        if f_state[q] == ACTIVE:
            if slot >= 0 or fs_rel[q] <= s:
                return s, -1
            slot = q
            end = min(end, fs_rel[q])
            if s < fs_rs[q]:  # its damping changes there
                end = min(end, fs_rs[q])
            if fs_x0[q] != fs_x1[q]:  # held while _finger_x is x0 (before ms) or x1 (after both)
                if fs_ms[q] <= s <= max(fs_ms[q], fs_me[q]):
                    return s, -1
                if s < fs_ms[q]:
                    end = min(end, fs_ms[q])
        elif f_state[q] == IDLE:
            if fs_on[q] <= s:
                return s, -1
            end = min(end, fs_on[q])
    if slot < 0:
        return s, -1
    for d in range(dp_on.shape[0]):
        if dp_on[d] <= s < dp_off[d]:
            return s, -1
        if dp_on[d] > s and dp_on[d] < end:
            end = dp_on[d]
    return end, slot


@njit(**JIT_STEP)
def _held_run(c, geo, ctl, st, w, slot, U0, U1, UF, out, it, it_end, step0, s_last, diag, e_h,
              e_q, e_p):
    """Held steps it, it + 1, ... (< it_end) of a fretted note, held by finger ``slot`` (its
    interpolant in ``w``), on u^n = U0, u^(n-1) = U1 and the scratch UF (the caller's rotation of
    ``st``'s three arrays); returns (steps done, S of the last u^n looked at).

    A held step is the general step of a held note, whose kind does not change from one step to
    the next: the Kirchhoff-Carrier column (if on), one finger in contact pressing the string,
    the rigid constraints of the active set (the frets the string rests on, any node resting on
    a rigid board), and nothing else.  The caller
    guarantees what acts on the string (``_held_until``); each step checks what the general path
    would decide, and the first step on which any of it differs is not taken (its u_free is
    scratch) and goes to the general path:
    * no node of u^n below a Hertzian fretboard (no fretboard column);
    * the finger in contact (gamma = 1 under the joint rule of sec. 4.7);
    * every rigid reaction >= 0 and no other fret or node of a rigid board penetrated (the
      active set stays);
    * the joint rule leaves the finger's gamma at 1 (``_joint_gamma`` would change nothing).
    The step is then the general path's arithmetic on the same helpers, in the same order, and
    both loops are compiled without fastmath and call the same linear pass (``config.JIT_STEP``),
    so the samples are identical (``tests/engine/test_held.py``, ``tools/held_soak.py``).
    It saves the general path's bookkeeping: the columns are laid out once per run, and the
    entries of the Gram matrix that do not involve the dense Kirchhoff-Carrier column, which depend
    only on the fixed interpolants, are worked out once (by ``_gram`` itself, so they are the same
    numbers).  With ``diag`` it books the energy terms as the general path does
    (``_step_energy``).
    """
    Q, psi, f_state, tens, fret_active = st.q, st.psi, st.f_state, st.tens, st.fret_active
    f_w, f_w1, f_psi, f_bprev = st.f_w, st.f_w1, st.f_psi, st.f_bprev
    fret_p, fret_w0, fret_w1, fret_m0 = geo.fret_p, geo.fret_w0, geo.fret_w1, geo.fret_m0
    out_p, out_w0, out_w1 = geo.out_p, geo.out_w0, geo.out_w1
    pl_start, pl_len, pl_amp, pl_p, pl_w0, pl_w1 = (
        ctl.pl_start, ctl.pl_len, ctl.pl_amp, ctl.pl_p, ctl.pl_w0, ctl.pl_w1)
    tb_step, tb_ratio = ctl.tb_step, ctl.tb_ratio
    bnear, near, count = geo.bnear, geo.near, _counted(c, geo)
    b2, c0, c1, ih2 = c.b2, c.c0, c.c1, c.ih2
    force = ctl.fs_force[slot]
    kind, cslot, cfret, cstart, cidx, cval, ca, cc = (
        w.kind, w.cslot, w.cfret, w.cstart, w.cidx, w.cval, w.ca, w.cc)
    vfree, v1, G, A, x, scr, du = w.vfree, w.v1, w.g, w.a, w.x, w.scr, w.du
    cgam, cs, cbt, ccon, fbeta, fchi = w.cgam, w.cs, w.cbt, w.ccon, w.fbeta, w.fchi
    fpos, fw0, fw1 = w.fp[slot], w.fw0[slot], w.fw1[slot]
    n = c.n
    k = c.k
    lam = c.lam
    b0 = c.b0
    b1 = c.b1
    lam_f = k * k / c.fg_mass
    nfret = fret_p.shape[0]
    ratio = 1.0
    # the columns, laid out as the general path lays them out: KC, the finger, the active frets
    nc = 0
    cstart[0] = 0
    if c.kc > 0.0:
        kind[0] = KC
        cslot[0] = -1
        nc = 1
        cstart[1] = 0
    fc = nc
    kind[fc] = FINGER
    cslot[fc] = slot
    cidx[0] = fpos
    cval[0] = fw0
    cidx[1] = fpos + 1
    cval[1] = fw1
    nc += 1
    cstart[nc] = 2
    nent = 2
    for q in range(nfret):
        if fret_active[q]:  # (vfree and v1 are worked out again in each step)
            nent = _add_rigid(q, nc, kind, cslot, cfret, cstart, cidx, cval, nent, fret_p,
                              fret_w0, fret_w1, fret_m0, UF, U1, ca, vfree, v1)
            nc += 1
    _gram(nc, kind, cstart, cidx, cval, cslot, Q, 0.0, lam, lam_f, G, scr)  # the fixed entries
    vlv = lam * (fw0 * fw0 + fw1 * fw1) + lam_f
    # the finger's contact damping: a run does not straddle the step where it changes
    # (``_held_until``)
    fr = w.fr
    fr[slot] = ctl.fs_r[slot] if step0 + it >= ctl.fs_rs[slot] else c.fg_r
    rdamp = fr[slot] / (2.0 * k)  # R / (2 k)
    done = 0
    for i in range(it, it_end):
        step = step0 + i
        _ends(U0, n)
        if tb_step.shape[0] > 0:  # a bend: the stencil under this step's tension
            ratio, b0, b1 = _bent_stencil(c, tb_step, tb_ratio, step)
        qq = quf = qu1 = 0.0
        if c.kc > 0.0:
            qq, quf, qu1, s, below, _ = _pass_kc(n, b0, b1, b2, c0, c1, ih2, U0, U1, UF, Q, bnear,
                                                 near, count)
        else:
            s, below, _ = _pass(n, b0, b1, b2, c0, c1, ih2, U0, U1, UF, bnear, near, count)
        if c.board_k > 0.0 and below > 0:  # the Hertzian board's column
            return done, s_last
        quf = _pluck_forces(c, step, UF, Q, quf, pl_start, pl_len, pl_amp, pl_p, pl_w0, pl_w1)
        # the finger, eqs. (39), (25)-(27), (55c-d), as in the general path
        wfree = _w_free(f_w[slot], f_w1[slot], lam_f, -force)
        eta = _eta(fw0, fw1, fpos, U0, f_w[slot])
        if not eta > 0.0:
            return done, s_last
        eta1 = _eta(fw0, fw1, fpos, U1, f_w1[slot])
        etaf = _eta(fw0, fw1, fpos, UF, wfree)
        bt = _beta(c, eta)
        cc[fc], ca[fc] = _finger_row(bt, f_psi[slot], eta1, 1.0, rdamp)
        vfree[fc] = etaf
        v1[fc] = eta1
        if c.kc > 0.0:
            ca[0] = c.kc * qu1
            cc[0] = c.kc
            vfree[0] = quf
            v1[0] = qu1
            _gram_kc(0, nc, cstart, cidx, cval, Q, qq, lam, G)  # the rest of G is fixed
        for ci in range(fc + 1, nc):
            vfree[ci], v1[ci] = _rigid_row(cfret[ci], fret_p, fret_w0, fret_w1, UF, U1)
        _assemble(nc, kind, ca, cc, vfree, G, A, x)
        if not _solve(A, x, nc):
            return done, s_last
        for ci in range(fc + 1, nc):
            if x[ci] < 0.0:  # a fret would leave the active set
                return done, s_last
        if c.fret_mode == 1:
            xk = _scatter(nc, kind, cstart, cidx, cval, x, lam, du)
            add = _fret_hit(c.kc > 0.0, True, below > 0, _borrowed(UF), _borrowed(du),
                            _borrowed(Q), _borrowed(fret_p), _borrowed(fret_w0),
                            _borrowed(fret_w1), _borrowed(fret_m0), _borrowed(fret_active),
                            geo.nfret, lam * xk)
            _unscatter(nc, cstart, cidx, du)
            if add >= 0:  # a fret would join it
                return done, s_last
        else:
            xk = x[0] if c.kc > 0.0 else 0.0
        # the joint rule of sec. 4.7 on the finger, in contact with gamma 1 so far: a change
        # means a second solve, which the general path does
        cgam[fc] = 1.0
        cs[fc] = bt * bt * vlv
        cbt[fc] = bt
        ccon[fc] = True
        fbeta[slot] = bt
        fchi[slot] = 1.0
        if _joint_gamma(fc + 1, kind, cslot, cstart, cval, ca, cc, vfree, v1, x, G, cgam, cs,
                        cbt, ccon, psi, f_psi, fbeta, fchi, fr, k, nc):
            return done, s_last
        # the step is a held one: apply it, z^(n+1) = z_free + Lambda sum_c v_c x_c
        f_bprev[slot] = bt
        for ci in range(fc, nc):
            for e in range(cstart[ci], cstart[ci + 1]):
                UF[cidx[e]] += lam * cval[e] * x[ci]
        if xk != 0.0:
            _add_kc(n, UF, Q, lam * xk)
        wn = wfree - lam_f * x[fc]
        etan = _eta(fw0, fw1, fpos, UF, wn)
        deta = etan - v1[fc]
        f_psi[slot] += 0.5 * bt * deta
        qloss = 0.0
        pin = 0.0
        if diag:
            dr = deta / (2.0 * k)
            qloss += 1.0 * fr[slot] * dr * dr * k
            pin += -force * (wn - f_w1[slot]) * 0.5
        f_w1[slot] = f_w[slot]
        f_w[slot] = wn
        if diag:
            for ci in range(fc + 1, nc):  # the reactions' work, booked as a loss
                q = cfret[ci]
                p_ = fret_p[q]
                sn = fret_w0[q] * UF[p_] + fret_w1[q] * UF[p_ + 1]
                qloss -= x[ci] * (sn - v1[ci]) * 0.5
        _pickups(out_p, out_w0, out_w1, UF, U0, k, out, i)
        if diag:
            _step_energy(c, ratio, step, step0, i, UF, U0, U1, psi, f_state, f_psi, f_w, f_w1,
                         pl_start, pl_len, pl_amp, pl_p, pl_w0, pl_w1, pin, 0.0, qloss, tens,
                         e_h, e_q, e_p)
        s_last = s
        U0, U1, UF = UF, U0, U1  # u^(n-1) <- u^n <- u^(n+1)
        done += 1
    return done, s_last
