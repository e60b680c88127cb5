"""The sample loop of one waveguide string (numba): terminations, junctions, collisions, pickups.

Per sample, in this order (all at time step s; a point's values at s depend only on step s - 1):

1. the period: the note's frequency f(s), the stopped string's (``config``) times the pitch
   ratio of the breakpoints (bends, vibrato) and of the tension-modulation glide (``glide``,
   every ``GLIDE_EVERY`` samples), P = fs / f, exact every ``GLIDE_EVERY`` samples (and where
   the schedules restart: every ``BLOCK`` steps and where the stop changes) and linear between;
   the termination's fractional delay D = P - 2 (N - n_t) - tau, and the termination walks one
   grid step when D leaves [1, 3) (``string``; at most one step a sample, which the slow pitch
   changes never exceed);
2. the termination at n_t: Lagrange read of u- at delay D, the loss one-pole, the dispersion
   allpass cascade, the reflection -g_f, written to u+(n_t, s);
3. the bridge: u-(N, s) = -u+(N, s);
4. the junctions that act at s (``pluck``: plucks, light fingers, harmonic touches, palm mutes),
   and a pluck's force as a velocity blow (``pluck._blow``); a junction whose point the
   termination has cut off does nothing and starts afresh when its point is back (``pluck``,
   "Passivity"), as a collision point forgets its arrival speed (``collision``);
5. the collision junctions whose bound reaches their obstacle (``collision``);
6. the pickups: velocity (u(s) - u(s - 1)) fs at each, times its gain, summed into ``out``;
7. on the grid of ``BLOCK`` steps, the decay stop: when nothing but the decay would happen in the
   next ``LOOKAHEAD`` steps (``_may_sleep``) and the pickups' output since the last test and
   every point's velocity on the sounding grid are below ``decay_velocity`` (``_still``), the
   call ends with ``carry.stopped``: ``voice`` keeps the state and the string sleeps until its
   next event, or stops when none is left (a sleeping string costs nothing).  Before it, the
   damped rest: a string under a plain damper (``_damped``) whose pickups have fallen below
   ``rest_v`` and whose points move slower than ``damped_v`` is held at rest, its state set to
   zero (``_settle``, ``WaveguideOptions.damped_velocity``), which the decay stop then finds
   still: part of the model, decided with the decay stop off too.

A move onto a new rest line (``voice._change``: a finger carrying the string onto a fret's crown,
or letting it up) is stepped here too, before each of its steps (``_ramp``): those steps and the
one after the last are general steps that restart the schedules (as ``carry.fresh`` does), and no
string sleeps while a finger moves it.  (Stepped from Python, one kernel call a step, the moves
cost a MIDI song's render over half its CPU time.)

The period's stretch, the reach schedule, the live collision points and a quiet string's
respite carry from one call to the next (``Wave.carry``): the schedules restart only on the
global grid of ``BLOCK`` steps and where ``voice`` asks (``carry.fresh``: the start, a change of
the stop; ``carry.fresh`` = 2 resumes a string that slept on the global grid), so a render gives
the same samples however its calls are cut, and a live session
(``engine.live``), whose calls end at its blocks and which learns of events only as they come,
gives the samples of the render of its events.  For that, nothing a call decides may depend on
an event more than ``LOOKAHEAD`` steps ahead (the session acts on events that much after they
come): the period's stretch looks ``GLIDE_EVERY`` steps ahead at the pitch ratio, the reach
``REACH_EVERY`` steps ahead at the junctions; a quiet string's respite, which reaches to the
next ``BLOCK`` step, ends at a call's start if a junction or a pitch breakpoint now falls within
it.

That is a general step.  Most steps need only 1-3 and 6 (and 5 for the collision points found live):
no junction acts but steady ones (``_steady``: dampers in contact, released junctions leaking away,
which the plain loop steps with the general step's arithmetic), the period is only stepped, no
reach is due.  Those run in ``_plain``, a loop of their own up to the next step that needs the
general one (a period update every ``GLIDE_EVERY`` steps, a reach, a junction's onset, pulse,
release or end), compiled apart so that its few values stay in registers; with a
steady period (no glide or bend moving it) it stops recomputing the delay once a step has neither
walked the termination nor moved the taps (every later step of the run would compute the same), and
a single pickup keeps its constants and last displacement in registers; while the glide moves the
period, a step whose period lies in the window where it could neither walk the termination nor move
the taps (``_window``, with a margin far above the rounding) skips the delay's computation and reads
the Lagrange taps' three older inputs from registers.  The live collision points are tested for
being cut off by the termination only after it has walked or the reach has listed them anew
(``_inside``).
All are compiled without fastmath (``config.JIT_STEP``): they round alike, so the samples do not
depend on where a plain run starts or ends.  Collision reach (``_reach``) runs every ``REACH_EVERY``
steps; when the string is quiet (no junction, a steady pitch, and the energy bound ``QUIET_MARGIN``
times below every obstacle) it is not needed again before the next ``BLOCK`` step.  The filters'
states live in registers for a call (``_terminate``), and ring indices are masked by a mask the
compiler knows to be non-negative (no wraparound test).

Constants imported from ``collision``, ``glide`` and ``pluck`` are compiled into the cached
kernel, and so are their inlined functions (``glide._slope_sum``): numba's cache only watches this
file, so after changing one of them, touch this file (and change it in the commit, or another
checkout keeps the old kernel).

Rails: u+(n, s) = R[(s - n) & mask], u-(n, s) = Mb[(s + n) & mask] (power-of-two ring buffers);
the offsets s - n and s + n grow with s, so nothing is copied as the waves travel.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from ..config import JIT_HELPER, JIT_INLINE, JIT_STEP
from .collision import NO_PREV, REACH_EVERY, _collide
from .glide import GLIDE_EVERY, _slope_sum
from .pluck import J_CUT, LEAK_HZ, _blow, _envelope, _msd

HISTORY = 64  # samples of the u- history at the termination that the reach bound covers
ENERGY_SAFETY = 2.0  # the energy bound's allowance for what the termination's filters hold
# The glide's exact period and the reach schedule restart at every multiple of BLOCK (and where
# ``voice`` asks: ``Carry.fresh``), and the decay stop is tested there.
BLOCK = 1024
QUIET_MARGIN = 2.0  # a quiet string's energy bound stays this far below every obstacle
MAX_SECTIONS = 4  # dispersion allpass sections at most (``string``)
NONNEG = (1 << 62) - 1
LOOKAHEAD = max(GLIDE_EVERY, REACH_EVERY)  # steps ahead a call looks at the events
SIXTH = 1.0 / 6.0  # the Lagrange taps multiply by it (a division per tap cost as much as the rest)
# the Lagrange taps follow the delay in steps of this fraction of the loop's period: while the
# glide moves it by far less than that a sample they are not computed again every sample (the
# loop's period off by at most 5e-6 of itself: 1200 log2(1 + 5e-6) = 0.0087 cent at most)
TAP_REL = 5e-6
WINDOW_MARGIN = 1e-9  # samples (``_window``)
RESTED, SLEEP = 1, 2  # ``_settle``'s verdicts (flags)

# The kernel's inputs are records (numpy structured dtypes, numba ``Record``s): each array of
# records costs one unboxing per call whatever its fields, and a field is read at a fixed offset.
_I, _F = np.int64, np.float64
# the string's constants for its current stop (``voice._configure``): one record
CONFIG = np.dtype([
    ("n", _I),  # N: the bridge's grid index
    ("disp_m", _I),  # dispersion allpass sections in use (<= MAX_SECTIONS)
    ("fs", _F),  # the sample rate
    ("loss_g", _F), ("loss_a", _F),  # the loss one-pole g (1 + a) / (1 + a z^-1)
    ("disp_a", _F),  # the allpasses' coefficient
    ("refl_g", _F),  # |reflection| of the termination
    ("tau", _F),  # the filters' phase delay at the fundamental, samples
    ("gain", _F),  # a bound on the termination's gain (``string.Loop.gain_bound``)
    ("glide_k", _F),  # the tension-modulation glide's constant (0: no glide, ``glide``)
    ("dcap", _F),  # the largest fractional delay the ring holds
    ("fbase", _F),  # the stopped string's frequency, Hz
    ("decay_v", _F),  # the decay stop's velocity (<= 0: no decay stop)
    ("rest_v", _F),  # the damped rest's bound on the pickups (``_settle``; <= 0: no rest)
    ("damped_v", _F),  # and on the points of a string under a plain damper (``_damped``)
    ("x_k0", _F),  # X / K0: a force's displacement per newton (``pluck._blow``)
    ("steady_runs", _I),  # 1: steady junctions run in plain runs (``_steady``), 0: not
    ("damper_bound", _I),  # 1: a damper's neighbours by the energy bound (``_reach``), 0: live
], align=True)
# what carries from one call to the next: one record
CARRY = np.dtype([
    ("n_t", _I),  # the termination's grid index
    ("pb", _I),  # the pitch breakpoint in force
    ("next_stop", _I),  # the next change of the stop (``voice``; the call ends there)
    ("stopped", _I),  # 1 once the decay stop has acted
    ("restart", _I),  # the step the period and reach schedules last restarted at
    ("quiet", _I),  # the step until which a quiet string needs no reach (``_reach``)
    ("nlive", _I),  # how many collision points are live
    ("fresh", _I),  # 1: the next call restarts the schedules (``voice``: the start, a new stop);
    # 2: it resumes a string that slept (``voice._wake``): the period exact and a reach at its
    # first step, the schedules on the global grid (``restart`` set by ``voice``), as if it had run
    ("ramp_left", _I),  # steps left of a move onto a new rest line (``voice._change``, ``RAMP``)
    ("ramp_n", _I),  # the grid points it moves (the first ramp_n of ``Wave.ramp``)
    ("general", _I),  # steps run in the general step, counted over the calls (``tools``)
    ("plain", _I),  # and in plain runs (``_plain``)
    ("tested", _I),  # collision point-steps tested (each live point at each step), likewise
    ("rests", _I),  # damped rests (``_settle``; with the stop off, again at each test), likewise
    ("loss", _F),  # the loss one-pole's state
    ("glide", _F),  # the glide's pitch ratio
    ("d", _F),  # the delay the Lagrange taps were computed for (0: none yet)
    ("peak", _F),  # the pickups' largest |output| since the last decay test
    ("period", _F),  # the loop's period, samples
    ("dper", _F),  # its step per sample
    ("ap_x", _F, (MAX_SECTIONS,)),  # the allpass sections' last inputs
    ("ap_y", _F, (MAX_SECTIONS,)),  # and outputs
], align=True)
# a junction (``pluck``): its contact's onset, end, pulse length, release and points (a row of
# ``POINT``s)
SLOT = np.dtype([("on", _I), ("off", _I), ("length", _I), ("rel", _I), ("npts", _I)], align=True)
# a junction's point: grid index, force share (N), mass, damping and stiffness (``pluck._msd``)
POINT = np.dtype([("n", _I), ("f", _F), ("mp", _F), ("rho", _F), ("kappa", _F)], align=True)
# a pitch breakpoint: step and ratio (linear between them)
BEND = np.dtype([("step", _I), ("ratio", _F)], align=True)
# a collision point (``collision``): grid index, whether live, the live points' indices listed
# first (``order``), the obstacle's height from the rest line, restitution, last displacement
COLLIDER = np.dtype([("n", _I), ("live", _I), ("order", _I), ("ref", _F), ("cr", _F),
                     ("prev", _F)], align=True)
# a pickup: grid index n and weight w of its interpolant (between n and n + 1), gain, last
# displacement
PICKUP = np.dtype([("n", _I), ("w", _F), ("g", _F), ("u", _F), ("jump", _F)], align=True)
# a move onto a new rest line (``voice._change``): a grid point and its displacement's change per
# step (half on each rail); the pickups' last reading moves by their ``jump`` per step
RAMP = np.dtype([("n", _I), ("d", _F)], align=True)
# the reach's per-segment maxima of |u+| and |u-| (``_reach``'s scratch)
SEGMENT = np.dtype([("up", _F), ("down", _F)], align=True)


class Wave(NamedTuple):
    """The string as the kernel steps it (built by ``voice``)."""

    config: np.ndarray  # (1,) CONFIG
    carry: np.ndarray  # (1,) CARRY
    rails: np.ndarray  # (2, 2^k): R (u+) and Mb (u-), ring buffers
    pickups: np.ndarray  # PICKUP
    colliders: np.ndarray  # COLLIDER
    segments: np.ndarray  # SEGMENT, N // REACH_EVERY + 2 of them
    ramp: np.ndarray  # RAMP, one per grid point at most


class Events(NamedTuple):
    """What acts on the string (built by ``voice`` from its ``controls.Timeline``)."""

    slots: np.ndarray  # SLOT per junction
    points: np.ndarray  # (junctions, pluck.MAX_POINTS) POINT
    jst: np.ndarray  # (junctions, pluck.MAX_POINTS, pluck.J_STATE) floats: ``pluck._msd``'s state
    bends: np.ndarray  # BEND


@njit(**JIT_STEP)
def run_block(wave, events, step0, out):
    """Run len(out) samples from step0 into out; returns the number run (fewer if the decay stop
    acted: ``carry.stopped`` is then 1), -1 if the string became non-finite, or -2 if the reach's
    segments do not fit this kernel's ``REACH_EVERY`` (a kernel cached from another value of it:
    numba's cache watches only this file).  The records' fields are taken out as scalars or as
    arrays (field views) once, before the loop."""
    cf = wave.config[0]
    st = wave.carry[0]
    nsteps = out.shape[0]
    N = cf.n
    disp_m = cf.disp_m
    x_k0 = cf.x_k0
    R = wave.rails[0]
    Mb = wave.rails[1]
    ap_x = st.ap_x
    ap_y = st.ap_y
    slots = events.slots
    js_on = slots.on
    js_off = slots.off
    js_len = slots.length
    js_rel = slots.rel
    js_np = slots.npts
    pts = events.points
    js_idx = pts.n
    js_f = pts.f
    js_mp = pts.mp
    js_rho = pts.rho
    js_kappa = pts.kappa
    jst = events.jst
    pb_step = events.bends.step
    pb_f = events.bends.ratio
    col = wave.colliders
    col_n = col.n
    col_live = col.live
    col_list = col.order
    col_ref = col.ref
    col_cr = col.cr
    col_prev = col.prev
    seg_p = wave.segments.up
    seg_m = wave.segments.down
    pk = wave.pickups
    pk_n = pk.n
    pk_w = pk.w
    pk_g = pk.g
    pk_u = pk.u
    pk_jump = pk.jump
    rp_n = wave.ramp.n
    rp_d = wave.ramp.d
    if seg_p.shape[0] < N // REACH_EVERY + 2:
        return -2
    mask = (R.shape[0] - 1) & NONNEG  # known >= 0: indices masked by it need no wraparound
    fs = cf.fs
    loss_gg = cf.loss_g * (1.0 + cf.loss_a)
    loss_a = cf.loss_a
    disp_a = cf.disp_a
    refl = -cf.refl_g
    tau = cf.tau
    gain = cf.gain
    glide_k = cf.glide_k
    dcap = cf.dcap
    fbase = cf.fbase
    decay_v = cf.decay_v
    rest_v = cf.rest_v
    damped_v = cf.damped_v
    watch = decay_v > 0.0 or rest_v > 0.0  # the tests on the BLOCK grid (``_settle``)
    next_stop = st.next_stop
    leak = math.exp(-2.0 * math.pi * LEAK_HZ / fs)
    tail = int(8.0 * fs / (2.0 * math.pi * LEAK_HZ))  # steps for h to leak to e^-8 of itself
    nslot = js_on.shape[0]
    # the junctions that can act in this call or in the BLOCK after it (whose onset comes before
    # then and whose window, to the end of its leak, reaches into the call), in their order:
    # all that ``_active``, ``_reach`` and ``_may_sleep`` can find at any step of the call, so
    # they look at these alone (``_near``): a song's string has hundreds of junctions, a call a
    # few, and the scratch below is sized by them
    jn, njn = _near(js_on, js_off, js_rel, tail, step0, step0 + nsteps + BLOCK)
    # the junctions whose window (onset to the end of their leak) holds the step, in their order,
    # and the step at which that list next changes (``_active``)
    act = np.empty(njn, np.int64)
    near_n = np.empty(njn * js_idx.shape[1], np.int64)  # ``_reach``'s scratch
    # the steady junctions' points in a plain run (``_steady``): grid index, coefficient, state
    sp_n = np.empty(njn * js_idx.shape[1], np.int64)
    sp_c = np.empty(njn * js_idx.shape[1])
    sp_h = np.empty(njn * js_idx.shape[1])
    sp_u = np.empty(njn * js_idx.shape[1])
    sp_cut = np.empty(njn * js_idx.shape[1])
    steady_runs = cf.steady_runs != 0
    nact = 0
    act_until = -1
    ncol = col_n.shape[0]
    npk = pk_n.shape[0]
    n_t = st.n_t
    ib = st.pb
    fresh = st.fresh == 1
    wake = st.fresh == 2
    st.fresh = 0
    # a finger carrying the string onto a new rest line (``voice._change``): its steps are general
    # steps that restart the schedules, as is the step after its last one (``_ramp``)
    ramp_left = st.ramp_left
    ramp_n = st.ramp_n
    after_ramp = False
    # the termination's filter states, in registers for the call
    ly = st.loss
    x0 = ap_x[0] if disp_m > 0 else 0.0
    x1 = ap_x[1] if disp_m > 1 else 0.0
    x2 = ap_x[2] if disp_m > 2 else 0.0
    x3 = ap_x[3] if disp_m > 3 else 0.0
    y0 = ap_y[0] if disp_m > 0 else 0.0
    y1 = ap_y[1] if disp_m > 1 else 0.0
    y2 = ap_y[2] if disp_m > 2 else 0.0
    y3 = ap_y[3] if disp_m > 3 else 0.0
    peak = st.peak
    nlive = st.nlive
    quiet_until = st.quiet  # reach not needed before this step (``_reach``)
    if quiet_until > step0:  # a junction or breakpoint come since it was decided ends it
        for j in range(nslot):
            if step0 <= js_on[j] < quiet_until:
                quiet_until = -1
        b = ib  # the breakpoints are in order: the first at or after step0
        while b < pb_step.shape[0] and pb_step[b] < step0:
            b += 1
        if b < pb_step.shape[0] and pb_step[b] < quiet_until:
            quiet_until = -1
    if wake:  # a reach at the first step
        quiet_until = -1
    period = st.period
    dper = st.dper
    d_taps = st.d  # the delay the taps were computed for (0 before the first call)
    j0, h0, h1, h2, h3 = _taps(d_taps if d_taps >= 1.0 else 1.5)
    ri = step0 - st.restart  # steps since the schedule's restart
    inside_nt = -1  # the place of the termination ``inside`` was found for (``_inside``)
    inside = False
    i = 0
    stopped = False
    plain = 0  # steps run in plain runs in this call
    tested = 0  # collision point-steps tested in this call
    while i < nsteps:
        # a general step: everything that may act at s
        s = step0 + i
        ramping = ramp_left > 0
        if ramping:
            _ramp(R, Mb, mask, s, rp_n, rp_d, ramp_n, pk_u, pk_jump)
            ramp_left -= 1
        renew = (i == 0 and fresh) or ramping or after_ramp  # the schedules start afresh
        after_ramp = ramping and ramp_left == 0
        if s >= act_until:  # the junctions whose window holds s (``_active``)
            nact, act_until = _active(js_on, js_off, js_rel, tail, s, act, jn, njn)
        # 1. the period, exact at a restart and every GLIDE_EVERY steps, linear in between
        # (the bends' breakpoints and the glide move it over milliseconds: no division per
        # sample), and the termination's place
        restart = renew or s % BLOCK == 0
        if restart:
            ri = 0
            st.restart = s
            if renew:
                quiet_until = -1
        exact = restart or (i == 0 and wake)
        phase = s % GLIDE_EVERY
        if exact or phase == 0:
            if glide_k > 0.0 and phase == 0:
                # between n_t + 1 and N - 1, whose values at s are final (the termination and
                # the bridge write theirs below), and u(N) = 0
                g_new = math.sqrt(1.0 + glide_k * _slope_sum(R, Mb, mask, s, n_t + 1, N - 1,
                                                             act, nact, js_off, js_rel, js_idx,
                                                             js_np, tail))
            else:
                g_new = st.glide
            ratio, ib = _ratio_at(s, pb_step, pb_f, ib)
            if exact:
                period = fs / (fbase * ratio * st.glide)
            ahead = GLIDE_EVERY - phase
            r_next, _ = _ratio_at(s + ahead, pb_step, pb_f, ib)
            dper = (fs / (fbase * r_next * g_new) - period) / ahead
            if abs(dper) * ahead < 1e-5:  # under 1e-5 samples a stretch: hold the taps
                dper = 0.0
            st.glide = g_new
        else:
            period += dper
        # 2. the termination at n_t, 3. the bridge
        (n_t, d_taps, j0, h0, h1, h2, h3, ly, x0, x1, x2, x3, y0, y1, y2, y3) = _terminate_step(
            R, Mb, mask, s, N, n_t, period, tau, dcap, d_taps, j0, h0, h1, h2, h3, loss_gg,
            loss_a, disp_a, disp_m, refl, ly, x0, x1, x2, x3, y0, y1, y2, y3)
        # 4. junctions: those whose window holds s (``_active``)
        if nact > 0:
            for a in range(nact):
                j = act[a]
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
                        # cut off by the termination (a glide, a bend, a stop): what it put
                        # on the string went with that part; it starts afresh when it is back
                        jst[j, k, J_CUT] = 1.0
                        continue
                    ip = (s - n) & mask
                    im = (s + n) & mask
                    uin = R[ip] + Mb[im]
                    if t == 0 or jst[j, k, J_CUT] != 0.0:
                        # the junction acts on the motion from its onset on, or from its
                        # point's return to the sounding string: a passive filter started at
                        # rest (``pluck``, "Passivity")
                        for q in range(5):
                            jst[j, k, q] = 0.0
                        jst[j, k, 5] = uin
                        jst[j, k, J_CUT] = 0.0
                    h = _msd(uin, jst, j, k, env * js_mp[j, k], env * js_rho[j, k],
                             env * js_kappa[j, k], leak)
                    R[ip] += 0.5 * h
                    Mb[im] += 0.5 * h
                    f = force * js_f[j, k]
                    if f != 0.0:
                        _blow(R, Mb, mask, s, n, N, 0.5 * x_k0 * f)
        # 5. collisions
        if ncol > 0:
            if (ri % REACH_EVERY == 0 or (i == 0 and wake)) and s >= quiet_until:
                nlive, quiet_until = _reach(R, Mb, mask, s, n_t, N, gain, col_n, col_ref,
                                            col_prev, col_live, col_list, seg_p, seg_m, js_on,
                                            js_off, js_rel, js_idx, js_np, js_f, js_mp,
                                            js_kappa, tail, pb_step, ib, near_n,
                                            cf.damper_bound != 0, jn, njn)
                inside_nt = -1
            if n_t != inside_nt:
                inside = _inside(col_n, col_list, nlive, n_t, N)
                inside_nt = n_t
            tested += nlive
            _collisions(R, Mb, mask, s, n_t, N, col_n, col_ref, col_cr, col_prev, col_list,
                        nlive, inside, fs)
        # 6. pickups
        acc = _pickups(R, Mb, mask, s, n_t, N, pk_n, pk_w, pk_g, pk_u, fs)
        out[i] = acc
        ri += 1
        i += 1
        if watch:
            peak = max(peak, abs(acc))
            if (s + 1) % BLOCK == 0:
                verdict = 0
                if not ramping:  # no rest and no sleep while a finger moves it
                    verdict = _settle(R, Mb, mask, s + 1, n_t, N, fs, peak, decay_v, rest_v,
                                      damped_v, next_stop, act, nact, js_on, js_off, js_rel,
                                      js_len, js_idx, js_np, js_mp, js_kappa, jst, col_prev,
                                      pk_u, pb_step, pb_f, ib, jn, njn)
                if verdict & RESTED:  # the filters' states, in registers, come to rest too
                    ly = x0 = x1 = x2 = x3 = y0 = y1 = y2 = y3 = 0.0
                    st.glide = 1.0
                    st.rests += 1
                if verdict & SLEEP:
                    stopped = True
                    break
                peak = 0.0
        # a plain run: steps at which nothing acts but the termination, the bridge, the live
        # collision points and the pickups (no junction, no update of the period or the reach),
        # the same arithmetic as the general step's in a loop of its own (``_plain``), up to the
        # next step that needs the general one
        if i >= nsteps or ramping:
            continue
        s1 = step0 + i
        e = min(s1 + (GLIDE_EVERY - s1 % GLIDE_EVERY) % GLIDE_EVERY, step0 + nsteps)
        if ncol > 0 and s1 >= quiet_until:
            e = min(e, s1 + (REACH_EVERY - ri % REACH_EVERY) % REACH_EVERY)
        if s1 >= act_until:
            nact, act_until = _active(js_on, js_off, js_rel, tail, s1, act, jn, njn)
        e = min(e, act_until)  # up to the next junction's onset or end
        nsp = 0
        if nact > 0:  # only steady junctions run in a plain run, up to their next change
            nsp, until = -1, s1
            if steady_runs:
                nsp, until = _steady(s1, act, nact, js_on, js_off, js_rel, js_len, js_np, js_idx,
                                     js_mp, js_rho, js_kappa, jst, sp_n, sp_c, sp_h, sp_u,
                                     sp_cut)
            e = min(e, until)
        if e > s1:
            (n_t, period, d_taps, j0, h0, h1, h2, h3, ly, x0, x1, x2, x3, y0, y1, y2, y3,
             peak) = _plain(R, Mb, mask, s1, e, step0, out, N, n_t, period, dper, tau, dcap,
                            d_taps, j0, h0, h1, h2, h3, loss_gg, loss_a, disp_a, disp_m, refl,
                            ly, x0, x1, x2, x3, y0, y1, y2, y3, pk_n, pk_w, pk_g, pk_u, fs, peak,
                            col_n, col_ref, col_cr, col_prev, col_list, nlive, sp_n, sp_c, sp_h,
                            sp_u, sp_cut, nsp, leak)
            if nsp > 0:  # the steady junctions' states back where the general step keeps them
                q = 0
                for a in range(nact):
                    j = act[a]
                    for k in range(js_np[j]):
                        jst[j, k, 0] = sp_h[q]
                        jst[j, k, 5] = sp_u[q]
                        jst[j, k, J_CUT] = sp_cut[q]
                        q += 1
            i += e - s1
            ri += e - s1
            plain += e - s1
            tested += (e - s1) * nlive if ncol > 0 else 0
            if watch and e % BLOCK == 0:
                verdict = _settle(R, Mb, mask, e, n_t, N, fs, peak, decay_v, rest_v, damped_v,
                                  next_stop, act, nact, js_on, js_off, js_rel, js_len, js_idx,
                                  js_np, js_mp, js_kappa, jst, col_prev, pk_u, pb_step, pb_f,
                                  ib, jn, njn)
                if verdict & RESTED:
                    ly = x0 = x1 = x2 = x3 = y0 = y1 = y2 = y3 = 0.0
                    st.glide = 1.0
                    st.rests += 1
                if verdict & SLEEP:
                    stopped = True
                    break
                peak = 0.0
    if stopped:
        st.stopped = 1
        peak = 0.0
    st.ramp_left = ramp_left
    if after_ramp:  # the next call's first step restarts the schedules
        st.fresh = 1
    st.general += i - plain
    st.plain += plain
    st.tested += tested
    st.n_t = n_t
    st.pb = ib
    st.quiet = quiet_until
    st.nlive = nlive
    st.period = period
    st.dper = dper
    st.d = d_taps
    st.loss = ly
    st.peak = peak
    if disp_m > 0:
        ap_x[0] = x0
        ap_y[0] = y0
    if disp_m > 1:
        ap_x[1] = x1
        ap_y[1] = y1
    if disp_m > 2:
        ap_x[2] = x2
        ap_y[2] = y2
    if disp_m > 3:
        ap_x[3] = x3
        ap_y[3] = y3
    for p in range(npk):
        if not math.isfinite(pk_u[p]):
            return -1
    return i


@njit(**JIT_HELPER)
def _terminate_step(R, Mb, mask, s, N, n_t, period, tau, dcap, d_taps, j0, h0, h1, h2, h3,
                    loss_gg, loss_a, disp_a, disp_m, refl, ly, x0, x1, x2, x3, y0, y1, y2, y3):
    """Steps 2 and 3 of sample s, the same in the general step and in ``_plain``: the termination
    at n_t, with the loop's period ``period`` (its place and taps: ``_walk``), and the bridge.
    Returns the state they change.

    A step towards the bridge leaves the loop two samples shorter on the grid and d two longer:
    the sample the termination would write now is the one it wrote a step ago (now one point
    further on), and its input the one it read then, so it does nothing this step.  A step
    towards the nut writes two samples, the old place's and the new one's, from two consecutive
    inputs."""
    (_, n_t, d_taps, j0, h0, h1, h2, h3, ly, x0, x1, x2, x3, y0, y1, y2, y3) = _walk_terminate(
        R, Mb, mask, s, N, n_t, period, tau, dcap, d_taps, j0, h0, h1, h2, h3, loss_gg, loss_a,
        disp_a, disp_m, refl, ly, x0, x1, x2, x3, y0, y1, y2, y3)
    Mb[(s + N) & mask] = -R[(s - N) & mask]
    return n_t, d_taps, j0, h0, h1, h2, h3, ly, x0, x1, x2, x3, y0, y1, y2, y3


@njit(**JIT_INLINE)
def _walk_terminate(R, Mb, mask, s, N, n_t, period, tau, dcap, d_taps, j0, h0, h1, h2, h3,
                    loss_gg, loss_a, disp_a, disp_m, refl, ly, x0, x1, x2, x3, y0, y1, y2, y3):
    """Step 2 of sample s (``_terminate_step`` without the bridge): the termination's place and
    taps for ``period`` (``_walk``), and what it writes there; returns the walk and the state."""
    walk, n_t, d_taps, j0, h0, h1, h2, h3 = _walk(period, N, n_t, tau, dcap, d_taps, j0, h0, h1,
                                                  h2, h3)
    if walk == -1:
        v, ly, x0, x1, x2, x3, y0, y1, y2, y3 = _terminate(
            Mb, mask, s + n_t - 1, j0, h0, h1, h2, h3, loss_gg, loss_a, disp_a, disp_m, refl,
            ly, x0, x1, x2, x3, y0, y1, y2, y3)
        R[(s - n_t - 1) & mask] = v
    if walk <= 0:
        v, ly, x0, x1, x2, x3, y0, y1, y2, y3 = _terminate(
            Mb, mask, s + n_t, j0, h0, h1, h2, h3, loss_gg, loss_a, disp_a, disp_m, refl,
            ly, x0, x1, x2, x3, y0, y1, y2, y3)
        R[(s - n_t) & mask] = v
    return walk, n_t, d_taps, j0, h0, h1, h2, h3, ly, x0, x1, x2, x3, y0, y1, y2, y3


@njit(**JIT_HELPER)
def _near(js_on, js_off, js_rel, tail, lo, hi):
    """The junctions that start before step hi and either start at lo or later or have a window
    (onset to the end of the leak) that reaches past lo, in their order: for a call from lo, with
    hi its end plus a ``BLOCK``, every junction that ``_active``, ``_reach`` (B and the quiet
    string's ``BLOCK`` ahead) and ``_may_sleep`` (``LOOKAHEAD`` ahead) can meet at its steps;
    the others would change none of their answers.  Returns the list and its length."""
    jn = np.empty(js_on.shape[0], np.int64)
    n = 0
    for j in range(js_on.shape[0]):
        if js_on[j] < hi and (js_on[j] >= lo or js_off[j] + js_rel[j] + tail > lo):
            jn[n] = j
            n += 1
    return jn, n


@njit(**JIT_HELPER)
def _active(js_on, js_off, js_rel, tail, s, act, jn, njn):
    """The junctions whose window, from the onset to the end of the leak (js_off + js_rel +
    tail), holds step s, listed in act in their order; returns how many and the first step after
    s at which the list changes (an active one's window ends or another's begins), that only up
    to the end of the call: the junctions looked at are ``jn[:njn]`` (``_near``)."""
    n = 0
    until = 1 << 62
    for q in range(njn):
        j = jn[q]
        end = js_off[j] + js_rel[j] + tail
        if js_on[j] > s:
            until = min(until, js_on[j])
        elif s < end:
            act[n] = j
            n += 1
            until = min(until, end)
    return n, until


@njit(**JIT_HELPER)
def _inside(col_n, col_list, nlive, n_t, N):
    """Do the live collision points all lie on the sounding string (n_t < n < N)?"""
    for q in range(nlive):
        n = col_n[col_list[q] & NONNEG]
        if n <= n_t or n >= N:
            return False
    return True


@njit(**JIT_HELPER)
def _collisions(R, Mb, mask, s, n_t, N, col_n, col_ref, col_cr, col_prev, col_list, nlive,
                inside, fs):
    """The live collision points at step s (``_collide``); a point the termination has cut off
    forgets its arrival speed (``NO_PREV``).  ``inside``: none is cut off (``_inside``), so
    that the loop tests no place."""
    if inside:
        for q in range(nlive):
            c = col_list[q] & NONNEG
            col_prev[c] = _collide(R, Mb, mask, s, col_n[c], col_ref[c], col_cr[c], col_prev[c],
                                   fs)
        return
    for q in range(nlive):
        c = col_list[q] & NONNEG
        n = col_n[c]
        if n <= n_t or n >= N:
            col_prev[c] = NO_PREV  # cut off: no arrival speed when it is back
            continue
        col_prev[c] = _collide(R, Mb, mask, s, n, col_ref[c], col_cr[c], col_prev[c], fs)


@njit(**JIT_HELPER)
def _tap_tol(period):
    """How far (samples) the delay may move from the one the taps were computed for before they
    are computed again, for a loop of ``period`` samples (``TAP_REL``)."""
    return TAP_REL * period


@njit(**JIT_HELPER)
def _walk(period, N, n_t, tau, dcap, d_taps, j0, h0, h1, h2, h3):
    """The termination's place and taps for the loop's period ``period``: the fractional delay
    d = period - 2 (N - n_t) - tau is kept in [1, 3) by walking n_t one point (walk = +1
    towards the bridge, -1 towards the nut, else 0); the taps follow d in steps of
    ``_tap_tol``.  Returns (walk, n_t, d_taps, j0, h0, h1, h2, h3)."""
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
    if abs(d - d_taps) >= _tap_tol(period):
        j0, h0, h1, h2, h3 = _taps(d)
        d_taps = d
    return walk, n_t, d_taps, j0, h0, h1, h2, h3


@njit(**JIT_STEP)
def _plain(R, Mb, mask, s1, e, step0, out, N, n_t, period, dper, tau, dcap, d_taps, j0, h0, h1,
           h2, h3, loss_gg, loss_a, disp_a, disp_m, refl, ly, x0, x1, x2, x3, y0, y1, y2, y3,
           pk_n, pk_w, pk_g, pk_u, fs, peak, col_n, col_ref, col_cr, col_prev, col_list, nlive,
           sp_n, sp_c, sp_h, sp_u, sp_cut, nsp, leak):
    """Steps s1 .. e - 1 of ``run_block`` when no junction acts but steady ones (``_steady``:
    ``nsp`` points, their states in sp_*) and neither the period's exact value nor the reach is
    due: the period's linear step, the termination, the bridge, the steady junctions, the live
    collision points and the pickups, as in the general step (a function of its own, so that the
    compiler keeps this loop's few values in registers).  Returns the state it changes."""
    mask &= NONNEG  # known >= 0 here too
    # a single pickup (the usual case): its constants and last displacement in registers
    one = pk_n.shape[0] == 1
    pn = pk_n[0] if one else 0
    pw = pk_w[0] if one else 0.0
    pw1 = 1.0 - pw
    pg = pk_g[0] if one else 0.0
    pu = pk_u[0] if one else 0.0
    # a steady period (dper = 0) at a step that neither walked the termination nor moved the
    # taps: every later step of the run computes the same delay, so it only terminates
    steady = False
    # the period window in which a step changes neither the place nor the taps (``_window``),
    # and the Lagrange read's last three inputs (the collisions write u-(n) for n > n_t only at
    # steps before the termination reads it)
    plo, phi = _window(N, n_t, tau, dcap, d_taps, period)
    base = s1 + n_t - j0
    m1 = Mb[(base - 1) & mask]
    m2 = Mb[(base - 2) & mask]
    m3 = Mb[(base - 3) & mask]
    inside = _inside(col_n, col_list, nlive, n_t, N)
    # the steady junctions' points all on the sounding string and none back from a cut: their
    # loop needs neither test (``_sounding``), until the termination walks
    sounding = _sounding(sp_n, sp_cut, nsp, n_t, N)
    for s in range(s1, e):
        fast = steady
        if not steady:
            period += dper
            if plo < period < phi:
                steady = dper == 0.0
                fast = True
        if fast:
            m0 = Mb[(s + n_t - j0) & mask]
            v, ly, x0, x1, x2, x3, y0, y1, y2, y3 = _filters(
                h0 * m0 + h1 * m1 + h2 * m2 + h3 * m3, loss_gg, loss_a, disp_a, disp_m, refl, ly,
                x0, x1, x2, x3, y0, y1, y2, y3)
            R[(s - n_t) & mask] = v
            Mb[(s + N) & mask] = -R[(s - N) & mask]
            m3 = m2
            m2 = m1
            m1 = m0
        else:
            nt_was = n_t
            d_was = d_taps
            (n_t, d_taps, j0, h0, h1, h2, h3, ly, x0, x1, x2, x3, y0, y1, y2,
             y3) = _terminate_step(R, Mb, mask, s, N, n_t, period, tau, dcap, d_taps, j0, h0, h1,
                                   h2, h3, loss_gg, loss_a, disp_a, disp_m, refl, ly, x0, x1, x2,
                                   x3, y0, y1, y2, y3)
            steady = dper == 0.0 and n_t == nt_was and d_taps == d_was
            if n_t != nt_was:
                inside = _inside(col_n, col_list, nlive, n_t, N)
                sounding = _sounding(sp_n, sp_cut, nsp, n_t, N)
            plo, phi = _window(N, n_t, tau, dcap, d_taps, period)
            base = s + 1 + n_t - j0
            m1 = Mb[(base - 1) & mask]
            m2 = Mb[(base - 2) & mask]
            m3 = Mb[(base - 3) & mask]
        # the general step's junctions, for steady dampers (``_steady``)
        if sounding:  # with neither test of the loop below taken
            for q in range(nsp):
                _damper(R, Mb, mask, s, sp_n[q], q, sp_c, sp_h, sp_u, leak)
        else:
            for q in range(nsp):
                n = sp_n[q]
                if n <= n_t or n >= N:  # cut off by the termination (as in the general step)
                    sp_cut[q] = 1.0
                    continue
                if sp_cut[q] != 0.0:  # back on the sounding string: afresh
                    sp_h[q] = 0.0
                    sp_u[q] = R[(s - n) & mask] + Mb[(s + n) & mask]
                    sp_cut[q] = 0.0
                _damper(R, Mb, mask, s, n, q, sp_c, sp_h, sp_u, leak)
        _collisions(R, Mb, mask, s, n_t, N, col_n, col_ref, col_cr, col_prev, col_list, nlive,
                    inside, fs)
        if one:  # ``_pickups`` for one pickup, the same arithmetic
            if pn <= n_t or pn + 1 > N:
                u = 0.0
            else:
                u = (pw1 * (R[(s - pn) & mask] + Mb[(s + pn) & mask])
                     + pw * (R[(s - pn - 1) & mask] + Mb[(s + pn + 1) & mask]))
            acc = 0.0
            acc += pg * (u - pu) * fs
            pu = u
        else:
            acc = _pickups(R, Mb, mask, s, n_t, N, pk_n, pk_w, pk_g, pk_u, fs)
        out[(s - step0) & NONNEG] = acc  # s >= step0: the mask only tells the compiler so
        peak = max(peak, abs(acc))
    if one:
        pk_u[0] = pu
    return n_t, period, d_taps, j0, h0, h1, h2, h3, ly, x0, x1, x2, x3, y0, y1, y2, y3, peak


@njit(**JIT_INLINE)
def _damper(R, Mb, mask, s, n, q, sp_c, sp_h, sp_u, leak):
    """Steady damper point q at grid point n, step s: ``pluck._msd``'s damper branch,
    h = leak h + c du on the arriving displacement's increment, half of h on each rail."""
    ip = (s - n) & mask
    im = (s + n) & mask
    uin = R[ip] + Mb[im]
    du = uin - sp_u[q]
    sp_u[q] = uin
    h = leak * sp_h[q] + sp_c[q] * du
    sp_h[q] = h
    R[ip] += 0.5 * h
    Mb[im] += 0.5 * h


@njit(**JIT_HELPER)
def _sounding(sp_n, sp_cut, nsp, n_t, N):
    """Do the steady junctions' points ``sp_n[:nsp]`` all lie on the sounding string
    (n_t < n < N), none of them cut off before (``sp_cut``)?"""
    for q in range(nsp):
        if sp_n[q] <= n_t or sp_n[q] >= N or sp_cut[q] != 0.0:
            return False
    return True


@njit(**JIT_HELPER)
def _steady(s, act, nact, js_on, js_off, js_rel, js_len, js_np, js_idx, js_mp, js_rho, js_kappa,
            jst, sp_n, sp_c, sp_h, sp_u, sp_cut):
    """Are the junctions ``act[:nact]`` all steady at step s, and until when?  A junction is
    steady while it is a constant damper: in a steady contact after its onset (no pulse, no mass
    or spring: a damp, a palm, a light finger, a harmonic touch; up to its end js_off), or gone,
    its perturbation leaking away (``pluck._msd`` with no contact: up to the end of its window).
    Then its step at a point is ``_msd``'s damper branch, h = leak h + c du with c = -2 rho /
    (1 + rho) (rho = 0 when gone), which ``_plain`` runs with the same arithmetic (its states
    in sp_*, in the general step's order; the damper never reads the mass branch's history, so
    that is not kept).  Returns the number of points listed and the first step after s at which
    one of them changes phase, or (-1, s) if some junction is not steady at s."""
    q = 0
    until = 1 << 62
    for a in range(nact):
        j = act[a]
        gone = js_off[j] + js_rel[j]
        if js_len[j] == 0 and js_on[j] < s < js_off[j]:
            env = 1.0
            for k in range(js_np[j]):
                if js_mp[j, k] != 0.0 or js_kappa[j, k] != 0.0:
                    return -1, s
            until = min(until, js_off[j])
        elif gone <= s:
            env = 0.0
        else:  # its onset, a pulse, a release
            return -1, s
        for k in range(js_np[j]):
            rho = env * js_rho[j, k]
            sp_n[q] = js_idx[j, k]
            sp_c[q] = -2.0 * rho / (1.0 + rho)
            sp_h[q] = jst[j, k, 0]
            sp_u[q] = jst[j, k, 5]
            sp_cut[q] = jst[j, k, J_CUT]
            q += 1
    return q, until


@njit(**JIT_HELPER)
def _ramp(R, Mb, mask, s, rp_n, rp_d, ramp_n, pk_u, pk_jump):
    """One step of a move onto a new rest line (``voice._change``), before step s: the
    displacement from the rest line at each of its points changes by d, half on each rail (a
    balanced displacement with no velocity, E&E eq. (12)), and the pickups' last reading by
    their jump, so that they see the string's motion, not the change of frame."""
    for k in range(ramp_n):
        R[(s - rp_n[k]) & mask] += 0.5 * rp_d[k]
    for k in range(ramp_n):
        Mb[(s + rp_n[k]) & mask] += 0.5 * rp_d[k]
    for p in range(pk_u.shape[0]):
        pk_u[p] += pk_jump[p]


@njit(**JIT_HELPER)
def _window(N, n_t, tau, dcap, d_taps, period):
    """The periods p, plo < p < phi, for which ``_walk`` at n_t neither walks the termination nor
    moves the taps from d_taps: its delay d = p - 2 (N - n_t) - tau stays in [1, 3) and within
    the taps' tolerance of d_taps, with a margin of ``WINDOW_MARGIN`` samples (far above the
    rounding of d), so that a step inside it may skip ``_walk`` and give the same samples.  The
    tolerance is taken at the smallest period the window can hold (below ``period`` by less than
    a sample: the window is narrower than 2 tolerances).  Empty (plo > phi) when there is no
    such period."""
    tol = _tap_tol(period - 1.0)
    lo = max(1.0, d_taps - tol) + WINDOW_MARGIN
    hi = min(3.0, dcap, d_taps + tol) - WINDOW_MARGIN
    base = 2.0 * (N - n_t) + tau
    return lo + base, hi + base


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
    a = x - 1.0
    b = x - 2.0
    c = x - 3.0
    return (j0, -(a * b * c) * SIXTH, x * b * c * 0.5, -(x * a * c) * 0.5, x * a * b * SIXTH)


@njit(**JIT_INLINE)
def _terminate(Mb, mask, at, j0, h0, h1, h2, h3, loss_gg, loss_a, disp_a, disp_m, refl, ly,
               x0, x1, x2, x3, y0, y1, y2, y3):
    """The termination's output: Lagrange read of the u- history before index ``at`` (taps
    ``_taps``), then ``_filters``; returns the output and the states."""
    base = at - j0
    y = (h0 * Mb[base & mask] + h1 * Mb[(base - 1) & mask] + h2 * Mb[(base - 2) & mask]
         + h3 * Mb[(base - 3) & mask])
    return _filters(y, loss_gg, loss_a, disp_a, disp_m, refl, ly, x0, x1, x2, x3, y0, y1, y2, y3)


@njit(**JIT_INLINE)
def _filters(y, loss_gg, loss_a, disp_a, disp_m, refl, ly, x0, x1, x2, x3, y0, y1, y2, y3):
    """The termination's filters on the Lagrange read y: the loss one-pole (gain
    loss_gg = g (1 + a), state ly), the dispersion allpasses (disp_m of the MAX_SECTIONS, states
    x, y), the reflection; returns the output and the states."""
    y = loss_gg * y - loss_a * ly
    ly = y
    if disp_m > 0:  # the sections' states are scalars, so that they stay in registers
        y, x0, y0 = _allpass(disp_a, y, x0, y0)
        if disp_m > 1:
            y, x1, y1 = _allpass(disp_a, y, x1, y1)
            if disp_m > 2:
                y, x2, y2 = _allpass(disp_a, y, x2, y2)
                if disp_m > 3:
                    y, x3, y3 = _allpass(disp_a, y, x3, y3)
    return refl * y, ly, x0, x1, x2, x3, y0, y1, y2, y3


@njit(**JIT_HELPER)
def _allpass(a, y, x, yo):
    """One first-order allpass section on input y, its last input x and output yo: returns its
    output a y + x - a yo and its new state (y, that output)."""
    v = a * y + x - a * yo
    return v, y, v


@njit(**JIT_INLINE)
def _pickups(R, Mb, mask, s, n_t, N, pk_n, pk_w, pk_g, pk_u, fs):
    """The pickups' velocity (u(s) - u(s - 1)) fs at each, times its gain, summed; each one's
    displacement kept in pk_u for the next step."""
    acc = 0.0
    for p in range(pk_n.shape[0]):
        n = pk_n[p]
        if n <= n_t or n + 1 > N:
            u = 0.0
        else:
            w = pk_w[p]
            u = ((1.0 - w) * (R[(s - n) & mask] + Mb[(s + n) & mask])
                 + w * (R[(s - n - 1) & mask] + Mb[(s + n + 1) & mask]))
        acc += pk_g[p] * (u - pk_u[p]) * fs
        pk_u[p] = u
    return acc


@njit(**JIT_HELPER)
def _may_sleep(t, next_stop, js_on, js_off, js_rel, js_len, pb_step, pb_f, ib, jn, njn):
    """May a still string sleep from step t (``_still``)?  Only if nothing but its decay would
    happen in the next ``LOOKAHEAD`` steps: no junction starts there, no pulse (or its release)
    is under way, the stop does not change there (``next_stop``, from ``voice``) and the pitch
    ratio neither changes there nor moves (the breakpoints' segment holding t is flat).  What a
    sleeping string skips is its decay below the threshold: ``voice`` keeps its state and wakes
    it at its next event.  The test looks no further ahead than ``LOOKAHEAD``, so a live session,
    which knows no more than that, decides as a render does (``voice.rebuild``).  The junctions
    looked at are ``jn[:njn]`` (``_near``)."""
    end = t + LOOKAHEAD
    if next_stop < end:
        return False
    for q in range(njn):
        j = jn[q]
        if t <= js_on[j] < end:
            return False
        if js_len[j] > 0 and js_on[j] <= t < js_off[j] + js_rel[j]:
            return False
    npb = pb_step.shape[0]
    b = ib  # the breakpoints are in order: the last at or before t
    while b + 1 < npb and pb_step[b + 1] <= t:
        b += 1
    if b + 1 < npb and (pb_step[b + 1] < end or pb_f[b + 1] != pb_f[b]):
        return False
    return True


@njit(**JIT_HELPER)
def _settle(R, Mb, mask, t, n_t, N, fs, peak, decay_v, rest_v, damped_v, next_stop, act, nact,
            js_on, js_off, js_rel, js_len, js_idx, js_np, js_mp, js_kappa, jst, col_prev, pk_u,
            pb_step, pb_f, ib, jn, njn):
    """The tests on the grid of ``BLOCK`` steps, at step t (the last step run: t - 1), when
    nothing but the string's own decay and its steady dampers would act on it in the next
    ``LOOKAHEAD`` steps (``_may_sleep``; the caller: no finger moving it).  Returns a set of
    flags:

    * ``RESTED``: the damped rest.  A plain damper has rested on the string since before t - 1
      and stays past t + ``LOOKAHEAD`` (``_damped``), its pickups have moved slower than
      rest_v since the last test and its points slower than damped_v (``_still``): the hand
      holds it still (``_hold``: every state of the string, its junctions, collision points and
      pickups set to rest; the caller zeroes the filters' states it keeps in registers).  The
      junctions' leak lets a damped string creep back to its rest line for seconds below
      ``LEAK_HZ`` (``pluck``), with its pickups far below rest_v and its points above the decay
      stop's bound; the hand on a real string holds it there.  A model rule, not a skip: it acts
      with the decay stop off too, so the stop stays exact around it (docs/engine.md, "Skips").
    * ``SLEEP``: the decay stop.  Its pickups (since the last test) and every point have moved
      slower than decay_v (a string the rule above has just held: at rest).  The string sleeps
      until its next event, its state kept (``voice._sleep``).
    """
    if not _may_sleep(t, next_stop, js_on, js_off, js_rel, js_len, pb_step, pb_f, ib, jn, njn):
        return 0
    if (rest_v > 0.0 and peak < rest_v
            and _damped(t - 1, act, nact, js_on, js_off, js_len, js_np, js_mp, js_kappa)
            and _still(R, Mb, mask, t - 1, n_t, N, fs, peak, rest_v, damped_v, act, nact,
                       js_idx, js_np)):
        _hold(R, Mb, act, nact, js_np, jst, col_prev, pk_u)
        return RESTED | SLEEP if decay_v > 0.0 else RESTED  # at rest: still
    if decay_v > 0.0 and _still(R, Mb, mask, t - 1, n_t, N, fs, peak, decay_v, decay_v, act,
                                nact, js_idx, js_np):
        return SLEEP
    return 0


@njit(**JIT_HELPER)
def _hold(R, Mb, act, nact, js_np, jst, col_prev, pk_u):
    """The damped rest (``_settle``): the rails (the whole ring: the termination's history too),
    the junctions' states (their last input is now 0, the string's displacement), the collision
    points' last displacements (those cut off keep ``NO_PREV``) and the pickups' last readings
    at rest."""
    R[:] = 0.0
    Mb[:] = 0.0
    for a in range(nact):
        j = act[a]
        for k in range(js_np[j]):
            for q in range(J_CUT):
                jst[j, k, q] = 0.0
    for c in range(col_prev.shape[0]):
        if col_prev[c] != NO_PREV:
            col_prev[c] = 0.0
    for p in range(pk_u.shape[0]):
        pk_u[p] = 0.0


@njit(**JIT_INLINE)
def _still(R, Mb, mask, s, n_t, N, fs, peak, v_max, v_points, act, nact, js_idx, js_np):
    """Have the pickups (their largest |output| since the last test: peak) moved slower than
    v_max and has every point of the sounding string (n_t .. N) moved slower than v_points at
    step s?  The velocity is read off the rails, u(n, s) - u(n, s - 1) with
    u(n, s - 1) = R[s - 1 - n] + Mb[s - 1 + n]: the waves' values at s, one point further on,
    before the junctions of step s moved them; next to a junction that acts (a steady damper)
    that mixes its step-s perturbation into the difference, so those points are left out: they
    move with their neighbours.  The junctions whose window holds s are ``act[:nact]``
    (``_active``)."""
    if peak >= v_max:
        return False
    lim = v_points / fs
    for n in range(n_t, N + 1):
        du = (R[(s - n) & mask] + Mb[(s + n) & mask]) - (R[(s - 1 - n) & mask]
                                                         + Mb[(s - 1 + n) & mask])
        if abs(du) >= lim:
            near = False
            for a in range(nact):
                j = act[a]
                for k in range(js_np[j]):
                    if abs(js_idx[j, k] - n) <= 1:
                        near = True
            if not near:
                return False
    return True


@njit(**JIT_HELPER)
def _damped(s, act, nact, js_on, js_off, js_len, js_np, js_mp, js_kappa):
    """Is a plain damper (a contact with no pulse, mass or spring: a damp, a palm, a harmonic
    touch, a light finger) in contact with the string from before step s until at least
    ``LOOKAHEAD`` steps after it?  Such a string creeps back to its rest line slowly after its
    note has died (the junctions' leak, ``pluck``, passes what is slower than ``LEAK_HZ``): the
    damped rest's (``_settle``)."""
    for a in range(nact):
        j = act[a]
        if js_len[j] == 0 and js_on[j] < s and js_off[j] > s + LOOKAHEAD:
            plain = True
            for k in range(js_np[j]):
                if js_mp[j, k] != 0.0 or js_kappa[j, k] != 0.0:
                    plain = False
            if plain:
                return True
    return False


@njit(**JIT_STEP)
def _reach(R, Mb, mask, s, n_t, N, gain, col_n, col_ref, col_prev, col_live, col_list, seg_p,
           seg_m, js_on, js_off, js_rel, js_idx, js_np, js_f, js_mp, js_kappa, tail, pb_step, ib,
           near_n, damper_bound, jn, njn):
    """The collision points that the string can reach in the next ``REACH_EVERY`` samples
    (``collision``): col_live[c] = 1 for those, 0 for the rest, and their indices listed first
    in col_list.  Returns how many there are and the step until which no bound is needed: s if
    the next one is due in REACH_EVERY samples, or the next multiple of ``BLOCK``
    if the string is quiet: no junction acts and the pitch is steady until then, and the energy
    bound keeps every point ``QUIET_MARGIN`` times below its obstacle (the energy of the passive
    string does not grow while nothing acts on it, so the bound holds for all that time).
    ``near_n``: scratch for the points of the junctions acting before s + B (one per junction
    point at most); the junctions looked at are ``jn[:njn]`` (``_near``)."""
    mask &= NONNEG
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
    for n in range(lo, n_t):  # the u- history that the termination still reads
        b = abs(Mb[(s + n) & mask])
        if b > maxm:
            maxm = b
    # segment by segment, the maxima in registers and each rail value read once: u+(n + 1) is
    # the next point's u+(n), u-(n - 1) the last one's u-(n) (the sum in the same order)
    rp = R[(s - n_t) & mask]
    rm_prev = Mb[(s + n_t - 1) & mask]
    for k in range(n_t // B, N // B + 1):
        sp = 0.0
        sm = 0.0
        for n in range(max(n_t, k * B), min(N + 1, k * B + B)):
            rp_next = R[(s - n - 1) & mask]
            rm = Mb[(s + n) & mask]
            a = abs(rp)
            b = abs(rm)
            dp = rp - rp_next
            dm = rm - rm_prev
            slope += dp * dp + dm * dm
            rp = rp_next
            rm_prev = rm
            if a > sp:
                sp = a
            if b > sm:
                sm = b
        seg_p[k] = sp
        seg_m[k] = sm
        if sp > maxp:
            maxp = sp
        if sm > maxm:
            maxm = sm
    span = N - n_t + 2.0  # the sounding length in grid steps (and a little of the termination's)
    until = (s // BLOCK + 1) * BLOCK  # how long a quiet string needs no bound
    forced = False  # a force acts, or a contact with a mass (not a plain damper), before s + B
    # the points of the junctions that act before s + B (they make their neighbours live): those
    # of the junctions with a force, a mass or a spring from the start of near_n (nnear), those
    # of plain dampers from its end (ndamp; ``damper_bound``)
    nnear = 0
    ndamp = 0
    top = near_n.shape[0] - 1
    quiet = ib + 1 >= pb_step.shape[0] or until <= pb_step[ib]  # the pitch is steady
    for jq in range(njn):
        j = jn[jq]
        if js_on[j] < s + B and js_off[j] + js_rel[j] > s:
            pushes = not damper_bound
            for q in range(js_np[j]):
                if js_f[j, q] != 0.0 or js_mp[j, q] != 0.0 or js_kappa[j, q] != 0.0:
                    forced = True
                    pushes = True
            for q in range(js_np[j]):
                if pushes:
                    near_n[nnear] = js_idx[j, q]
                    nnear += 1
                else:
                    near_n[(top - ndamp) & NONNEG] = js_idx[j, q]
                    ndamp += 1
        if js_on[j] < until and js_off[j] + js_rel[j] + tail > s:
            quiet = False
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
            if quiet and e2 * (QUIET_MARGIN * QUIET_MARGIN) >= col_ref[c] * col_ref[c]:
                quiet = False
            damped = False  # within B of a damper: the segments' maxima assume free waves
            for q in range(ndamp):
                if abs(near_n[(top - q) & NONNEG] - n) <= B:
                    damped = True
                    break
            if damped or e2 < bound * bound:
                bound = math.sqrt(e2)
        live = bound * (1.0 + 1e-9) + 1e-15 >= -col_ref[c]
        if not live:
            for q in range(nnear):
                if abs(near_n[q] - n) <= B:
                    live = True
                    break
        if not live and forced:  # no energy bound: a damper's neighbours too
            for q in range(ndamp):
                if abs(near_n[(top - q) & NONNEG] - n) <= B:
                    live = True
                    break
        if live and col_live[c] == 0:
            col_prev[c] = R[(s - n) & mask] + Mb[(s + n) & mask]
        col_live[c] = 1 if live else 0
        if live:
            col_list[nlive] = c
            nlive += 1
    if forced or nlive > 0 or not quiet:
        return nlive, s
    return nlive, until
