"""The sample loop of one waveguide string (numba): terminations, junctions, collisions, pickups.

Per sample, in this order (all at time step s; a point's values at s depend only on step s - 1):

1. the period: the note's frequency f(s), the stopped string's (``cfg``) times the pitch
   ratio of the breakpoints (bends, vibrato) and of the tension-modulation glide (``glide``,
   every ``GLIDE_EVERY`` samples), P = fs / f, exact every ``GLIDE_EVERY`` samples and linear
   between;
   the termination's fractional delay D = P - 2 (N - n_t) - tau, and the termination walks one
   grid step when D leaves [1, 3) (``string``; at most one step a sample, which the slow pitch
   changes never exceed);
2. the termination at n_t: Lagrange read of u- at delay D, the loss one-pole, the dispersion
   allpass cascade, the reflection -g_f, written to u+(n_t, s);
3. the bridge: u-(N, s) = -u+(N, s);
4. the junctions that act at s (``pluck``: plucks, light fingers, harmonic touches, palm mutes),
   and a pluck's force as a velocity blow (``pluck._blow``);
5. the collision junctions whose bound reaches their obstacle (``collision``);
6. the pickups: velocity (u(s) - u(s - 1)) fs at each, times its gain, summed into ``out``.

Constants imported from ``collision``, ``glide`` and ``pluck`` are compiled into the cached
kernel: numba's cache only watches this file, so after changing one of them, touch this file.

Rails: u+(n, s) = R[(s - n) & mask], u-(n, s) = Mb[(s + n) & mask] (power-of-two ring buffers);
the offsets s - n and s + n grow with s, so nothing is copied as the waves travel.
"""

from __future__ import annotations

import math

from numba import njit

from ..config import JIT, JIT_INLINE
from .collision import REACH_EVERY, _collide
from .glide import GLIDE_EVERY, _slope_sum
from .pluck import LEAK_HZ, _blow, _envelope, _msd

# ist: integer state
I_NT, I_PB = 0, 1
# fst: float state; pickups' previous displacement from F_PICKUP on
F_LOSS, F_GLIDE, F_D, F_GSTEP, F_PICKUP = 0, 1, 2, 3, 4
# cfg: the current termination and string constants
C_LOSS_G, C_LOSS_A, C_DISP_A, C_REFL_G, C_TAU, C_GAIN, C_FS, C_GLIDE_K, C_DCAP, C_FBASE = range(10)
HISTORY = 64  # samples of the u- history at the termination that the reach bound covers
ENERGY_SAFETY = 2.0  # the energy bound's allowance for what the termination's filters hold


@njit(**JIT)
def run_block(R, Mb, ist, fst, dsx, dsy, step0, nsteps, out, cfg, disp_m, N,
              pb_step, pb_f,
              js_on, js_off, js_len, js_rel, js_idx, js_np, js_f, js_mp, js_rho, js_kappa, jst,
              x_k0,
              col_n, col_ref, col_cr, col_prev, col_live, col_list, seg_p, seg_m,
              pk_n, pk_w, pk_g):
    mask = R.shape[0] - 1
    fs = cfg[C_FS]
    loss_g = cfg[C_LOSS_G]
    loss_a = cfg[C_LOSS_A]
    disp_a = cfg[C_DISP_A]
    refl = -cfg[C_REFL_G]
    tau = cfg[C_TAU]
    gain = cfg[C_GAIN]
    glide_k = cfg[C_GLIDE_K]
    dcap = cfg[C_DCAP]
    fbase = cfg[C_FBASE]
    leak = math.exp(-2.0 * math.pi * LEAK_HZ / fs)
    tail = int(8.0 * fs / (2.0 * math.pi * LEAK_HZ))  # steps for h to leak to e^-8 of itself
    nslot = js_on.shape[0]
    slot_lo = 1 << 62
    slot_hi = -(1 << 62)
    for j in range(nslot):
        slot_lo = min(slot_lo, js_on[j])
        slot_hi = max(slot_hi, js_off[j] + js_rel[j] + tail)
    ncol = col_n.shape[0]
    npk = pk_n.shape[0]
    n_t = ist[I_NT]
    ib = ist[I_PB]
    nlive = 0
    period = 0.0
    dper = 0.0
    d_taps = -1.0
    j0, h0, h1, h2, h3 = _taps(1.5)
    for i in range(nsteps):
        s = step0 + i
        # 1. the period, exact at the first step and every GLIDE_EVERY steps, linear in between
        # (the bends' breakpoints and the glide move it over milliseconds: no division per
        # sample), and the termination's place
        phase = s % GLIDE_EVERY
        if i == 0 or phase == 0:
            if glide_k > 0.0 and phase == 0:
                # between n_t + 1 and N - 1, whose values at s are final (the termination and
                # the bridge write theirs below), and u(N) = 0
                g_new = math.sqrt(1.0 + glide_k * _slope_sum(R, Mb, mask, s, n_t + 1, N - 1))
            else:
                g_new = fst[F_GLIDE]
            ratio, ib = _ratio_at(s, pb_step, pb_f, ib)
            if i == 0:
                period = fs / (fbase * ratio * fst[F_GLIDE])
            ahead = GLIDE_EVERY - phase
            r_next, _ = _ratio_at(s + ahead, pb_step, pb_f, ib)
            dper = (fs / (fbase * r_next * g_new) - period) / ahead
            if abs(dper) * ahead < 1e-5:  # under 1e-5 samples a stretch: hold the taps
                dper = 0.0
            fst[F_GLIDE] = g_new
        else:
            period += dper
        d = period - 2.0 * (N - n_t) - tau
        walk = 0
        if d < 1.0 and n_t < N - 1:
            n_t += 1
            d += 2.0
            walk = 1
        elif d >= 3.0 and n_t > 0:
            n_t -= 1
            d -= 2.0
            walk = -1
        if d < 1.0:
            d = 1.0
        if d > dcap:
            d = dcap
        if d != d_taps:
            j0, h0, h1, h2, h3 = _taps(d)
            d_taps = d
        # 2. the termination at n_t.  A step towards the bridge leaves the loop two samples
        # shorter on the grid and D two longer: the sample the termination would write now is
        # the one it wrote a step ago (now one point further on), and its input the one it read
        # then, so it does nothing this step.  A step towards the nut writes two samples, the
        # old place's and the new one's, from two consecutive inputs.
        if walk == 0:
            R[(s - n_t) & mask] = _terminate(Mb, mask, s + n_t, j0, h0, h1, h2, h3, loss_g,
                                             loss_a, disp_a, disp_m, refl, fst, dsx, dsy)
        elif walk == -1:
            R[(s - n_t - 1) & mask] = _terminate(Mb, mask, s + n_t - 1, j0, h0, h1, h2, h3,
                                                 loss_g, loss_a, disp_a, disp_m, refl, fst, dsx,
                                                 dsy)
            R[(s - n_t) & mask] = _terminate(Mb, mask, s + n_t, j0, h0, h1, h2, h3, loss_g,
                                             loss_a, disp_a, disp_m, refl, fst, dsx, dsy)
        # 3. the bridge
        Mb[(s + N) & mask] = -R[(s - N) & mask]
        # 4. junctions (none before the first onset or after the last one is gone)
        for j in range(nslot if slot_lo <= s < slot_hi else 0):
            if s < js_on[j] or s >= js_off[j] + js_rel[j] + tail:
                continue
            t = s - js_on[j]
            if s < js_off[j]:
                env = _envelope(t, js_len[j])
                force = env if js_len[j] > 0 else 0.0
            elif s < js_off[j] + js_rel[j]:  # the contact lets go over js_rel steps
                r = math.cos(0.5 * math.pi * (s - js_off[j]) / js_rel[j])
                env = r * r
                force = 0.0
            else:  # gone; what it put on the string leaks away (``pluck._msd``)
                env = 0.0
                force = 0.0
            for k in range(js_np[j]):
                n = js_idx[j, k]
                if n <= n_t or n >= N:
                    continue
                ip = (s - n) & mask
                im = (s + n) & mask
                uin = R[ip] + Mb[im]
                st = jst[j, k]
                if t == 0:  # the junction acts on the motion from its onset on
                    for q in range(5):
                        st[q] = 0.0
                    st[5] = uin
                h = _msd(uin, st, env * js_mp[j, k], env * js_rho[j, k], env * js_kappa[j, k],
                         leak)
                R[ip] += 0.5 * h
                Mb[im] += 0.5 * h
                f = force * js_f[j, k]
                if f != 0.0:
                    _blow(R, Mb, mask, s, n, N, 0.5 * x_k0 * f)
        # 5. collisions
        if ncol > 0:
            if i % REACH_EVERY == 0:
                nlive = _reach(R, Mb, mask, s, n_t, N, gain, col_n, col_ref, col_prev, col_live,
                               col_list, seg_p, seg_m, js_on, js_off, js_rel, js_idx, js_np,
                               js_f, js_mp, js_kappa)
            for q in range(nlive):
                c = col_list[q]
                n = col_n[c]
                if n <= n_t or n >= N:
                    continue
                col_prev[c] = _collide(R, Mb, mask, s, n, col_ref[c], col_cr[c], col_prev[c],
                                       fs)
        # 6. pickups
        acc = 0.0
        for p in range(npk):
            n = pk_n[p]
            if n <= n_t or n + 1 > N:
                u = 0.0
            else:
                w = pk_w[p]
                u = ((1.0 - w) * (R[(s - n) & mask] + Mb[(s + n) & mask])
                     + w * (R[(s - n - 1) & mask] + Mb[(s + n + 1) & mask]))
            acc += pk_g[p] * (u - fst[F_PICKUP + p]) * fs
            fst[F_PICKUP + p] = u
        out[i] = acc
    ist[I_NT] = n_t
    ist[I_PB] = ib
    fst[F_D] = d_taps
    finite = True
    for p in range(npk):
        if not math.isfinite(fst[F_PICKUP + p]):
            finite = False
    return finite


@njit(**JIT_INLINE)
def _ratio_at(t, pb_step, pb_f, ib):
    """The pitch ratio at step t (linear between breakpoints) and the breakpoint index, searched
    forwards from ib."""
    npb = pb_step.shape[0]
    while ib + 1 < npb and pb_step[ib + 1] <= t:
        ib += 1
    if ib + 1 < npb and t >= pb_step[ib]:
        a = (t - pb_step[ib]) / (pb_step[ib + 1] - pb_step[ib])
        return pb_f[ib] + a * (pb_f[ib + 1] - pb_f[ib]), ib
    return pb_f[ib], ib


@njit(**JIT_INLINE)
def _taps(d):
    """Third-order Lagrange taps for a delay d >= 1 read as j0 + x, j0 = floor(d) - 1, x in
    [1, 2): (j0, h0, h1, h2, h3), the taps on samples j0 .. j0 + 3 back."""
    j0 = int(d) - 1
    x = d - j0
    return (j0, -(x - 1.0) * (x - 2.0) * (x - 3.0) / 6.0, x * (x - 2.0) * (x - 3.0) / 2.0,
            -x * (x - 1.0) * (x - 3.0) / 2.0, x * (x - 1.0) * (x - 2.0) / 6.0)


@njit(**JIT_INLINE)
def _terminate(Mb, mask, at, j0, h0, h1, h2, h3, loss_g, loss_a, disp_a, disp_m, refl, fst, dsx,
               dsy):
    """The termination's output: Lagrange read of the u- history before index ``at`` (taps
    ``_taps``), the loss one-pole, the dispersion allpasses, the reflection."""
    base = at - j0
    y = (h0 * Mb[base & mask] + h1 * Mb[(base - 1) & mask] + h2 * Mb[(base - 2) & mask]
         + h3 * Mb[(base - 3) & mask])
    y = loss_g * (1.0 + loss_a) * y - loss_a * fst[F_LOSS]
    fst[F_LOSS] = y
    for k in range(disp_m):
        v = disp_a * y + dsx[k] - disp_a * dsy[k]
        dsx[k] = y
        dsy[k] = v
        y = v
    return refl * y


@njit(**JIT)
def _reach(R, Mb, mask, s, n_t, N, gain, col_n, col_ref, col_prev, col_live, col_list, seg_p,
           seg_m, js_on, js_off, js_rel, js_idx, js_np, js_f, js_mp, js_kappa):
    """The collision points that the string can reach in the next ``REACH_EVERY`` samples
    (``collision``): col_live[c] = 1 for those, 0 for the rest, and their indices listed first
    in col_list; returns how many there are."""
    nlive = 0
    B = REACH_EVERY
    nseg = seg_p.shape[0]
    for k in range(nseg):
        seg_p[k] = 0.0
        seg_m[k] = 0.0
    maxp = 0.0
    maxm = 0.0
    slope = 0.0  # sum over the sounding grid of the rails' squared steps: E / T * X
    lo = n_t - HISTORY
    for n in range(lo, N + 1):
        a = abs(R[(s - n) & mask])
        b = abs(Mb[(s + n) & mask])
        if b > maxm:
            maxm = b
        if n < n_t:
            continue  # the u- history that the termination still reads
        dp = R[(s - n) & mask] - R[(s - n - 1) & mask]
        dm = Mb[(s + n) & mask] - Mb[(s + n - 1) & mask]
        slope += dp * dp + dm * dm
        k = n // B
        if a > seg_p[k]:
            seg_p[k] = a
        if b > seg_m[k]:
            seg_m[k] = b
        if a > maxp:
            maxp = a
    span = N - n_t + 2.0  # the sounding length in grid steps (and a little of the termination's)
    forced = False  # a force acts, or a contact with a mass (not a plain damper), before s + B
    for j in range(js_on.shape[0]):
        if js_on[j] < s + B and js_off[j] + js_rel[j] > s:
            for q in range(js_np[j]):
                if js_f[j, q] != 0.0 or js_mp[j, q] != 0.0 or js_kappa[j, q] != 0.0:
                    forced = True
    for c in range(col_n.shape[0]):
        n = col_n[c]
        if n <= n_t or n >= N:
            col_live[c] = 0
            continue
        k = n // B
        bp = seg_p[k]
        if k > 0 and seg_p[k - 1] > bp:
            bp = seg_p[k - 1]
        if n - B <= n_t + 4:
            bp = max(bp, gain * maxm)
        bm = seg_m[k]
        if k + 1 < nseg and seg_m[k + 1] > bm:
            bm = seg_m[k + 1]
        if n + B >= N:
            bm = max(bm, maxp)
        bound = bp + bm
        if not forced:  # the energy bound, tighter near the ends (``collision``)
            d = n - n_t + 1.0
            e2 = ENERGY_SAFETY * 2.0 * slope * d * (span - d) / span
            if e2 < bound * bound:
                bound = math.sqrt(e2)
        live = bound * (1.0 + 1e-9) + 1e-15 >= -col_ref[c]
        if not live:
            for j in range(js_on.shape[0]):
                if js_on[j] < s + B and js_off[j] + js_rel[j] > s:
                    for q in range(js_np[j]):
                        if abs(js_idx[j, q] - n) <= B:
                            live = True
        if live and col_live[c] == 0:
            col_prev[c] = R[(s - n) & mask] + Mb[(s + n) & mask]
        col_live[c] = 1 if live else 0
        if live:
            col_list[nlive] = c
            nlive += 1
    return nlive
