"""The time-step loop of one string: the DAFx24 scheme (Bilbao, Russo, Webb & Ducceschi 2024), sec. 4.

One step n -> n+1, in the order of the paper's sec. 5 breakdown:

a) linear update u_free = B u^n + C u^(n-1) + E f^n            eqs. (36), (50a-c)
   fused with q = D u^n and its dot products for the Kirchhoff-Carrier column    eqs. (37), (52)
   and with the smallest gap u^n - b to the fretboard (is a contact possible at all?)
b) the excitation f_e^n of eq. (5), spread by its interpolant                    eqs. (4), (19)
c) fretboard: SAV gradient g_B from eq. (54)-(55a), gradient correction gamma      sec. 4.7
d) frets: either penalty SAV (eqs. (24b), (55b)) or one-sided rigid constraints (the K_F -> inf
   limit; see below), finger(s): SAV contact with damping, eqs. (25)-(27), (39)-(41), (55c-d)
f) the small linear system, solved directly for the column multipliers (Woodbury without forming
   b^n of eq. (49); see ``../shared/papers/NOTES.md``), the psi updates of eq. (48), output.

Every nonlinear force enters the update as  z^(n+1) = z_free + Lambda * sum_c v_c x_c  with a sparse
column v_c (the dense exception is the Kirchhoff-Carrier column q = D u^n) and a scalar multiplier
x_c.  Each multiplier obeys one linear equation:

* penalty-like columns (KC, SAV contacts, finger):  x_c + c_c v_c^T z^(n+1) = -a_c
* an active rigid fret q:                            j_q^T u^(n+1) = m0_q
* an inactive rigid fret:                            x_q = 0

so the whole nonlinear part of a step is one dense solve of the size of the active set (usually 1 to
4).  The rigid frets use a warm-started active set (x_q >= 0 and j_q^T u^(n+1) >= m0_q); their
reaction does non-positive work, which the energy balance books as a loss (exactly).

Indexing: a string of N intervals has interior nodes 1..N-1.  Arrays ``U`` hold them with two ghost
cells each side: node i lives at U[i+1]; U[1] = U[N+1] = 0 are the fixed ends and U[0] = -U[2],
U[N+2] = -U[N] make D^2 the square of the Dirichlet D (simply supported ends, eq. (2)).  Loops run
over non-negative offsets (U[j], U[j+1] ... U[j+4]) so that LLVM vectorises them.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
from numba import njit

from .config import JIT, JIT_INLINE, JIT_NO_NRT, JIT_STEP

EPS = 2.220446049250313e-16  # the gauge constant epsilon of eq. (54)

# column kinds
KC, BOARD, FRETPEN, FINGER, RIGID, DAMPER = 0, 1, 2, 3, 4, 5
# finger slot states
IDLE, ACTIVE, GONE = 0, 1, 2
# status codes
OK, NONFINITE = 0, 1
# gradient-correction rules of sec. 4.7 (``Coefs.gamma_rule``): the engine's (``_gamma``, decided
# on the joint solution when contacts act together), the same rule on each column's own prediction
# only, eq. (61) as printed, and no correction (gamma = 1 in contact, 0 out of it)
GAMMA_JOINT, GAMMA_OWN, GAMMA_PAPER, GAMMA_NONE = 0, 1, 2, 3


class Coefs(NamedTuple):
    """Per-string constants of the scheme (all SI); built by ``engine.string``."""

    n: int  # N, number of grid intervals
    k: float  # time step, s
    h: float  # grid spacing, m
    lam: float  # Lambda for the string, k^2 / (rho A h (1 + sigma0 k)), eq. (51)
    b0: float  # stencil of B, eq. (50a): centre, +-1, +-2
    b1: float
    b2: float
    c0: float  # stencil of C, eq. (50b): centre, +-1
    c1: float
    ih2: float  # 1 / h^2
    kc: float  # E A h^2 / (4 L): Kirchhoff-Carrier weight (0 switches it off), eq. (37)
    rho_a_h: float  # rho A h, for the energy
    t0: float  # tension, N
    ei: float  # E I
    sigma0: float
    sigma1: float
    board_k: float  # K_B (0: no fretboard)
    board_alpha: float
    fret_mode: int  # 0 none, 1 rigid, 2 penalty
    fret_k: float
    fret_alpha: float
    fg_mass: float
    fg_k: float
    fg_alpha: float
    fg_r: float  # finger contact damping, N s / m
    fg_lift: float  # finger is removed once this far above the string, m
    lam2: float  # T0 k^2 / (rho A h^2): the tension's share of B, for bends
    den: float  # 1 + sigma0 k
    gamma_rule: int = GAMMA_JOINT  # sec. 4.7 variant, see ``_gamma`` (a knob of the accuracy study)
    # quiet steps leave the Kirchhoff-Carrier column out while S (``_linear_pass_kc``) of the step
    # before is below this: its tension rise E A S / (2 L h) is then below a stated share of T0
    # (``string.kc_skip_level``); 0 keeps it in every step
    kc_s_skip: float = 0.0


class Geo(NamedTuple):
    """Static geometry on the grid: fretboard, frets, pickups (built by ``engine.string``)."""

    board: np.ndarray  # b at nodes 1..N-1 (array index = node - 1)
    near: np.ndarray  # per node: level below which a rigid fret may be reached this step
    fret_p: np.ndarray  # per fret: padded index of the interpolant's left node
    fret_w0: np.ndarray
    fret_w1: np.ndarray
    fret_m0: np.ndarray  # fret tip heights m0 (<= 0)
    out_p: np.ndarray  # per pickup: interpolant
    out_w0: np.ndarray
    out_w1: np.ndarray
    # False: every step takes the general path (``RenderOptions.skip_contacts=False``)
    quiet: bool = True
    # False: the steps of a held note take the general path too (``RenderOptions.held_steps``)
    held: bool = True


class Controls(NamedTuple):
    """What the player does, as step-indexed arrays (built by ``engine.controls``)."""

    pl_start: np.ndarray  # plucks: first step, length in steps, signed peak force, interpolant
    pl_len: np.ndarray
    pl_amp: np.ndarray
    pl_p: np.ndarray
    pl_w0: np.ndarray
    pl_w1: np.ndarray
    fs_on: np.ndarray  # finger slots: put down, lifted, position x0 -> x1 over steps ms..me,
    fs_rel: np.ndarray  # pressing force, initial speed towards the board, initial gap
    fs_x0: np.ndarray
    fs_x1: np.ndarray
    fs_ms: np.ndarray
    fs_me: np.ndarray
    fs_force: np.ndarray
    fs_v0: np.ndarray
    fs_gap: np.ndarray
    dp_on: np.ndarray  # dampers (light touch, palm): active steps, damping N s/m, spread
    dp_off: np.ndarray
    dp_r: np.ndarray
    dp_ptr: np.ndarray  # entries dp_ptr[d] .. dp_ptr[d+1] of dp_idx (padded index) / dp_w
    dp_idx: np.ndarray
    dp_w: np.ndarray
    tb_step: np.ndarray  # tension T0 * ratio, piecewise linear between breakpoints
    tb_ratio: np.ndarray


class State(NamedTuple):
    """Everything that survives from one block to the next."""

    u: np.ndarray  # u^n (padded)
    u1: np.ndarray  # u^(n-1)
    uf: np.ndarray  # scratch
    q: np.ndarray  # scratch: D u^n at the N - 1 interior nodes, then a 0 (``_q_index``)
    psi: np.ndarray  # [fretboard, penalty frets]
    gprev_b: np.ndarray  # last contact gradients (for the out-of-contact rule)
    gprev_f: np.ndarray
    has_gprev: np.ndarray
    fret_active: np.ndarray  # rigid frets' active set
    f_state: np.ndarray  # finger slots: IDLE, ACTIVE, GONE
    f_w: np.ndarray  # w^n
    f_w1: np.ndarray  # w^(n-1)
    f_psi: np.ndarray
    f_bprev: np.ndarray
    tens: np.ndarray  # [T^(n-1), W^(n-1/2)] for the work done by a changing tension
    # [S of u^(n-1) (``_linear_pass_kc``), 1.0 if no contact acted in the last step, 1.0 if the
    # next step may be held]: decide quiet and held steps and the KC skip
    s_last: np.ndarray
    # [steps the quiet run has taken, steps the held run has taken] (for the tests and
    # benchmarks/skips.py)
    run_steps: np.ndarray


class Work(NamedTuple):
    """The general step's scratch, allocated by ``step_block`` for each block."""

    kind: np.ndarray  # column kinds of the small system (KC, FINGER, RIGID, ...)
    cstart: np.ndarray  # a column's entries are cidx/cval[cstart[c]:cstart[c + 1]]
    cslot: np.ndarray  # finger slot of the column (-1: none)
    cfret: np.ndarray  # fret of a rigid column
    ca: np.ndarray  # a and c of a column's row, x + c (G x + v_free) = -a (``_assemble``)
    cc: np.ndarray
    vfree: np.ndarray  # v^T u_free of each column
    v1: np.ndarray  # v^T u^(n-1)
    cidx: np.ndarray  # node indices, unsigned: no wrap-around (see _fret_hit)
    cval: np.ndarray
    g: np.ndarray  # the Gram matrix of the columns
    a: np.ndarray  # the small system
    x: np.ndarray
    xp: np.ndarray  # the rigid frets' last feasible multipliers (see the active-set loop)
    cgam: np.ndarray  # gamma of an SAV or finger column (sec. 4.7)
    cs: np.ndarray  # its s~ = v~^T Lambda v~ (unscaled gradient)
    cbt: np.ndarray  # a finger column's unscaled beta~
    ccon: np.ndarray  # in contact at u^n
    scr: np.ndarray  # a string-sized scratch (zero between uses)
    du: np.ndarray  # the columns' sum Lambda v x, scattered onto the string (``_scatter``)
    wfree: np.ndarray  # per finger slot: w_free
    fext: np.ndarray  # its external force in this step
    fp: np.ndarray  # the finger's interpolant: left node, weights
    fw0: np.ndarray
    fw1: np.ndarray
    fchi: np.ndarray
    fbeta: np.ndarray
    fcol: np.ndarray  # the finger's column (-1: none)
    rd: np.ndarray  # ``_ray_blocked``'s direction and system
    ra: np.ndarray


def _type_key(a):
    """What numba's ``typeof`` reads of an argument of the kinds the kernels take, as a hashable
    key: an array's dtype, dimensions, layout (C before F, as numba maps it), writability and
    alignment; a tuple's class and items, recursively; a scalar's Python type."""
    if isinstance(a, np.ndarray):
        f = a.flags
        layout = "C" if f.c_contiguous else "F" if f.f_contiguous else "A"
        return (a.dtype.str, a.ndim, layout, f.writeable, f.aligned)
    if isinstance(a, tuple):
        return (type(a), *(_type_key(v) for v in a))
    return type(a)


_ENTRIES: dict = {}


def entry_point(dispatcher, args):
    """The compiled function behind a numba dispatcher for the types of ``args``, compiled or
    loaded from the cache if need be.  Calling it skips the dispatcher's type resolution, which
    for the NamedTuples of arrays ``step_block`` takes costs more than the unboxing itself.
    Resolving the types once per string (numba's ``typeof`` of some sixty arrays) was itself a
    visible share of a short render, so the result is kept per process, keyed by ``_type_key``,
    which is much cheaper to compute.  Only for arguments of exactly these types (it unboxes by the
    signature it was compiled for).  With ``NUMBA_DISABLE_JIT=1`` the kernels are Python, indexed
    with numpy's bounds checks (``tests/engine/test_kernels.py`` renders that way)."""
    if not hasattr(dispatcher, "compile"):  # NUMBA_DISABLE_JIT=1: a plain Python function
        return dispatcher
    key = (dispatcher, _type_key(args))
    fn = _ENTRIES.get(key)
    if fn is None:
        fn = dispatcher.compile(tuple(dispatcher.typeof_pyval(a) for a in args))
        _ENTRIES[key] = fn
    return fn


@njit(**JIT_INLINE)
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


# The linear pass, a) of the step, is one compiled kernel (with fastmath, so that LLVM vectorises
# its float sums: S and the Kirchhoff-Carrier dot products) that the quiet run, the held run and
# the general path all call, through the inlined wrappers ``_linear_pass_kc`` and
# ``_linear_pass``.  The three loops therefore get the same sums to the last bit by construction;
# inlined into each loop (as they were up to 6e8d8bc), they relied on LLVM vectorising every copy
# the same way, which held for the quiet run and not for the held run.  The call costs each step
# a few ns (``docs/engine.md``); without reference counting (``config.JIT_NO_NRT``) it no longer
# counts the six arrays it passes.  The kernels take the coefficients they use, not ``Coefs``:
# every field passed is an argument to marshal in each call.
@njit(**JIT_NO_NRT)
def _pass_kc(n, b0, b1, b2, c0, c1, ih2, U0, U1, UF, Q, board, near, count):
    """a) + KC: u_free, q = D u^n, q.q, q.u_free, q.u^(n-1), S = sum of (u_(i+1) - u_i)^2 over
    the N intervals of u^n, and the nodes of u^n below the fretboard and within reach of a fret
    tip (``Geo.near``); returns (q.q, q.u_free, q.u^(n-1), S, below, close).

    S is the size of the Kirchhoff-Carrier tension rise (``Coefs.kc_s_skip``).  The counts are
    integers, which vectorise with the rest (a float min() does not).  They are taken unless
    ``count`` is False, which a string without fretboard and frets passes in every call
    (``_counted``): LLVM splits the loop in two versions on the flag, whose float sums it need
    not vectorise alike, so the flag must not differ between the loops that step one string.  Up
    to 520c8ee the quiet run passed another flag than the general path in the same step."""
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


@njit(**JIT_NO_NRT)
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


@njit(**JIT_INLINE)
def _counted(c, geo):
    """Does the linear pass count the nodes near a contact?  Not on a string without fretboard
    and frets (``benchmarks.speed``'s linear string), which has none to count; a property of the
    string, so every loop that steps it passes the same flag."""
    return c.board_k > 0.0 or geo.fret_p.shape[0] > 0


@njit(**JIT_INLINE)
def _linear_pass_kc(c, geo, b0, b1, U0, U1, UF, Q):
    """``_pass_kc`` with the string's coefficients (b0, b1: the stencil's, bent or not) and
    geometry."""
    return _pass_kc(c.n, b0, b1, c.b2, c.c0, c.c1, c.ih2, U0, U1, UF, Q, geo.board, geo.near,
                    _counted(c, geo))


@njit(**JIT_INLINE)
def _linear_pass(c, geo, b0, b1, U0, U1, UF):
    """``_pass`` with the string's coefficients and geometry."""
    return _pass(c.n, b0, b1, c.b2, c.c0, c.c1, c.ih2, U0, U1, UF, geo.board, geo.near,
                 _counted(c, geo))


@njit(**JIT_INLINE)
def _kc_multiplier(c, qq, quf, qu1):
    """The Kirchhoff-Carrier column alone (the common free-vibration step): a 1x1 system."""
    return -c.kc * (qu1 + quf) / (1.0 + c.kc * c.lam * qq)


@njit(**JIT_INLINE)
def _add_kc(n, UF, Q, a_):
    """z^(n+1) += Lambda x_KC q."""
    for j in range(n - 1):
        UF[j + 2] += a_ * Q[j]


@njit(**JIT_INLINE)
def _pickups(out_p, out_w0, out_w1, UF, U0, k, out, it):
    """Output: the string velocity (u^(n+1) - u^n) / k at each pickup."""
    for pk in range(out_p.shape[0]):
        po = out_p[pk]
        out[pk, it] = (
            out_w0[pk] * (UF[po] - U0[po]) + out_w1[pk] * (UF[po + 1] - U0[po + 1])
        ) / k


@njit(**JIT_NO_NRT)
def _quiet_until(s, ctl, st):
    """The first step >= s at which a quiet step is not allowed (s itself if step s is not quiet).

    A step may be quiet when nothing acts on the string but its own forces: no pluck force, no
    finger on the string or about to be put down, no damper, no residual psi of a contact, no
    rigid fret in the active set.  If no contact happens either (``_quiet_run`` checks each step),
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
    no node of u^n is below the fretboard, and either none is within reach of a fret tip (the
    counts of ``_pass_kc``) or (rigid frets) ``_fret_hit`` finds no fret penetrated by u^(n+1):
    the general path would look at the frets, find none to add and keep the Kirchhoff-Carrier
    column alone.
    The first step with a contact is not taken (its u_free is scratch) and goes to the general
    path.  A loop of its own: as a branch of ``step_block``'s loop the same step was slower (the
    general path's many variables crowd the loop).
    """
    Q, fret_active, du = st.q, st.fret_active, w.du
    fret_p, fret_w0, fret_w1, fret_m0 = geo.fret_p, geo.fret_w0, geo.fret_w1, geo.fret_m0
    out_p, out_w0, out_w1 = geo.out_p, geo.out_w0, geo.out_w1
    tb_step, tb_ratio = ctl.tb_step, ctl.tb_ratio
    n = c.n
    b0 = c.b0
    b1 = c.b1
    lam = c.lam
    tb_n = tb_step.shape[0]
    done = 0
    for i in range(it, it_end):
        U0[0] = -U0[2]
        U0[n + 2] = -U0[n]
        if tb_n > 0:
            _, b0, b1 = _bent_stencil(c, tb_step, tb_ratio, step0 + i)
        with_kc = c.kc > 0.0 and s_last >= c.kc_s_skip
        xk = 0.0
        if with_kc:
            qq, quf, qu1, s, below, close = _linear_pass_kc(c, geo, b0, b1, U0, U1, UF, Q)
            xk = _kc_multiplier(c, qq, quf, qu1)
        else:
            s, below, close = _linear_pass(c, geo, b0, b1, U0, U1, UF)
        if (below > 0 or close > 0) and _contact(c, below, close, UF, du, Q, fret_p, fret_w0,
                                                 fret_w1, fret_m0, fret_active, lam * xk):
            return done, s
        s_last = s
        if xk != 0.0:
            _add_kc(n, UF, Q, lam * xk)
        _pickups(out_p, out_w0, out_w1, UF, U0, c.k, out, i)
        U0, U1, UF = UF, U0, U1  # u^(n-1) <- u^n <- u^(n+1)
        done += 1
    return done, s_last


@njit(**JIT_INLINE)
def _pluck_force(step, e, pl_start, pl_len, pl_amp):
    """(acting, f): whether pluck e acts at this step, and its raised-sine force, eq. (5)."""
    m = step - pl_start[e]
    if m < 0 or m > pl_len[e]:
        return False, 0.0
    s_ = math.sin(0.5 * math.pi * m / pl_len[e])
    return True, pl_amp[e] * s_ * s_


@njit(**JIT_INLINE)
def _pluck_forces(c, step, UF, Q, quf, pl_start, pl_len, pl_amp, pl_p, pl_w0, pl_w1):
    """b) The plucks' forces f_e^n of eq. (5) added to u_free through their interpolants, eq. (19);
    returns q.u_free kept current (with Kirchhoff-Carrier)."""
    lam = c.lam
    for e in range(pl_start.shape[0]):
        acting, f = _pluck_force(step, e, pl_start, pl_len, pl_amp)
        if acting:
            p_ = pl_p[e]
            UF[p_] += lam * pl_w0[e] * f
            UF[p_ + 1] += lam * pl_w1[e] * f
            if c.kc > 0.0:
                quf += lam * f * (pl_w0[e] * Q[_q_index(p_)] + pl_w1[e] * Q[_q_index(p_ + 1)])
    return quf


@njit(**JIT_STEP)
def _contact(c, below, close, UF, du, Q, fret_p, fret_w0, fret_w1, fret_m0, fret_active, kq):
    """Does a contact act in a step with no other force (see ``_quiet_run``), given the counts of
    the linear pass, of which one is not 0?  Not inlined: a branch that the quiet steps of a
    soft pluck rarely take (inlined, it slowed their loop)."""
    if below > 0:
        return True
    if c.fret_mode != 1:  # penalty frets act on u^n: within reach is all there is to know
        return True
    return _fret_hit(c.kc > 0.0, UF, du, Q, fret_p, fret_w0, fret_w1, fret_m0, fret_active,
                     kq) >= 0


@njit(**JIT_INLINE)
def _q_index(p):
    """Index into Q (q = D u^n; Q[j] at node j + 1, so at padded node p = j + 2) of padded node p,
    unsigned so that numba leaves out the wrap-around of negative indices.  An interpolant in the
    first or last grid interval touches a fixed end (p = 1, or p + 1 = N + 1), which has no q and
    weight 0 (``interp``): node 1 is clamped to Q[0], and node N + 1 reads Q[N - 1], the element
    ``State.q`` carries past the N - 1 interior nodes, which stays 0.  (Wrapped, node 1 read the
    far end; without that element, node N + 1 read memory past Q.)"""
    return np.uint64(max(p - 2, 0))


@njit(**JIT_INLINE)
def _fret_hit(with_q, UF, du, Q, fret_p, fret_w0, fret_w1, fret_m0, fret_active, kq):
    """The rigid frets' active-set check: the fret outside the active set that the predicted
    u^(n+1) = u_free + du + kq q penetrates deepest (by more than 1e-12 m); -1 if none.  Every
    fret is looked at: which fret is added must not depend on the skip's margin.

    The indices are unsigned (see ``_q_index``): numba's wrap-around of negative indices cost a
    measurable share of a fretted step in this loop (``benchmarks.speed``)."""
    add = -1
    wval = -1e-12
    for q in range(fret_p.shape[0]):
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
    return add


@njit(**JIT_INLINE)
def _solve(A, r, n):
    """Solve A x = r in place (x into r); returns False if A is singular.

    The system is that of the column multipliers: with each non-rigid row divided by its c, it
    is symmetric, and positive definite unless rigid constraints depend on each other.  Most
    systems are arrowheads: the Kirchhoff-Carrier column (or the one column that is not narrow)
    couples to every other, and the narrow columns of a finger and of frets away from it share no
    node.  These are solved by eliminating the narrow columns into the first row
    (``_solve_arrow``): a handful of operations and no pivot search, where partial pivoting
    spent about a fifth of a held note's step (``docs/engine.md``).  Any other system goes to
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


@njit(**JIT_INLINE)
def _solve_sized(A, r, n):
    """``_solve`` for a size that is a literal where the caller can make it one."""
    if _is_arrow(A, n):
        return _solve_arrow(A, r, n)
    return _solve_n(A, r, n)


@njit(**JIT_INLINE)
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


@njit(**JIT_INLINE)
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


@njit(**JIT_INLINE)
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


@njit(**JIT_INLINE)
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


@njit(**JIT_NO_NRT)
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


@njit(**JIT_NO_NRT)
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


@njit(**JIT_INLINE)
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


@njit(**JIT_INLINE)
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


@njit(**JIT_NO_NRT)
def _held_until(s, ctl, st):
    """The first step >= s at which a held step is not allowed, and the finger slot that holds the
    string; (s, -1) if step s may not be held.

    A held step is a general step of a fixed kind (see ``_held_run``): one finger on the string,
    staying where it is and pressing, no other finger put down or lifted, no damper, no residual
    psi of the fretboard or the penalty frets.  Plucks may act (their forces are added as in the
    general path).  A sliding finger holds before its slide begins and after it ends: its
    interpolant, worked out in the general step before the run, is the one each step would get.
    Nothing of this changes in a held step, so the answer holds until the next general step.
    """
    psi, f_state = st.psi, st.f_state
    fs_on, fs_rel, fs_x0, fs_x1, fs_ms, fs_me = (
        ctl.fs_on, ctl.fs_rel, ctl.fs_x0, ctl.fs_x1, ctl.fs_ms, ctl.fs_me)
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
    the rigid frets of the active set (those the string rests on), and nothing else.  The caller
    guarantees what acts on the string (``_held_until``); each step checks what the general path
    would decide, and the first step on which any of it differs is not taken (its u_free is
    scratch) and goes to the general path:
    * no node of u^n below the fretboard (no fretboard column);
    * the finger in contact (gamma = 1 under the joint rule of sec. 4.7);
    * every rigid reaction >= 0 and no other fret penetrated (the active set stays);
    * the joint rule leaves the finger's gamma at 1 (``_joint_gamma`` would change nothing).
    The step is then the general path's arithmetic on the same helpers, in the same order, and
    both loops are compiled without fastmath and call the same linear pass (``config.JIT_STEP``),
    so the samples are identical (``tests/engine/test_held.py``, ``benchmarks/held_soak.py``).
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
    tb_n = tb_step.shape[0]
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
    cf_damp = 1.0 * c.fg_r / (2.0 * k)  # fchi * R / (2 k) in contact
    done = 0
    for i in range(it, it_end):
        step = step0 + i
        U0[0] = -U0[2]
        U0[n + 2] = -U0[n]
        if tb_n > 0:
            ratio, b0, b1 = _bent_stencil(c, tb_step, tb_ratio, step)
        qq = 0.0
        quf = 0.0
        qu1 = 0.0
        if c.kc > 0.0:
            qq, quf, qu1, s, below, _ = _linear_pass_kc(c, geo, b0, b1, U0, U1, UF, Q)
        else:
            s, below, _ = _linear_pass(c, geo, b0, b1, U0, U1, UF)
        if c.board_k > 0.0 and below > 0:
            return done, s_last
        quf = _pluck_forces(c, step, UF, Q, quf, pl_start, pl_len, pl_amp, pl_p, pl_w0, pl_w1)
        # the finger, eqs. (39), (25)-(27), (55c-d), as in the general path
        wfree = 2.0 * f_w[slot] - f_w1[slot] + lam_f * -force
        eta = fw0 * U0[fpos] + fw1 * U0[fpos + 1] - f_w[slot]
        if not eta > 0.0:
            return done, s_last
        eta1 = fw0 * U1[fpos] + fw1 * U1[fpos + 1] - f_w1[slot]
        etaf = fw0 * UF[fpos] + fw1 * UF[fpos + 1] - wfree
        ea = eta if c.fg_alpha == 1.0 else eta**c.fg_alpha
        vpot = c.fg_k / (c.fg_alpha + 1.0) * ea * eta
        bt = c.fg_k * ea / math.sqrt(2.0 * vpot + EPS)
        cf = 0.25 * bt * bt + cf_damp
        ca[fc] = bt * f_psi[slot] - cf * eta1
        cc[fc] = cf
        vfree[fc] = etaf
        v1[fc] = eta1
        if c.kc > 0.0:
            ca[0] = c.kc * qu1
            cc[0] = c.kc
            vfree[0] = quf
            v1[0] = qu1
            _gram_kc(0, nc, cstart, cidx, cval, Q, qq, lam, G)  # the rest of G is fixed
        for ci in range(fc + 1, nc):
            p_ = cidx[cstart[ci]]
            q = cfret[ci]
            vfree[ci] = fret_w0[q] * UF[p_] + fret_w1[q] * UF[p_ + 1]
            v1[ci] = fret_w0[q] * U1[p_] + fret_w1[q] * U1[p_ + 1]
        _assemble(nc, kind, ca, cc, vfree, G, A, x)
        if not _solve(A, x, nc):
            return done, s_last
        for ci in range(fc + 1, nc):
            if x[ci] < 0.0:  # a fret would leave the active set
                return done, s_last
        if c.fret_mode == 1:
            xk = _scatter(nc, kind, cstart, cidx, cval, x, lam, du)
            add = _fret_hit(c.kc > 0.0, UF, du, Q, fret_p, fret_w0, fret_w1, fret_m0,
                            fret_active, lam * xk)
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
                        cbt, ccon, psi, f_psi, fbeta, fchi, cf_damp, nc):
            return done, s_last
        # the step is a held one: apply it, z^(n+1) = z_free + Lambda sum_c v_c x_c
        f_bprev[slot] = bt
        for ci in range(fc, nc):
            for e in range(cstart[ci], cstart[ci + 1]):
                UF[cidx[e]] += lam * cval[e] * x[ci]
        if xk != 0.0:
            _add_kc(n, UF, Q, lam * xk)
        wn = wfree - lam_f * x[fc]
        etan = fw0 * UF[fpos] + fw1 * UF[fpos + 1] - wn
        deta = etan - v1[fc]
        f_psi[slot] += 0.5 * bt * deta
        qloss = 0.0
        pin = 0.0
        if diag:
            dr = deta / (2.0 * k)
            qloss += 1.0 * c.fg_r * dr * dr * k
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


@njit(**JIT)
def step_block(c, geo, ctl, st, step0, nsteps, out, diag, e_h, e_q, e_p):
    """Advance one string by ``nsteps`` steps from global step ``step0``.

    Fills ``out[pickup, step]`` (string velocity at each pickup, m/s) and, when ``diag``, the
    energy series e_h = H^(n+1/2), e_q = k Q^n and e_p = k P^n, where P also carries the energy a
    finger brings or takes away when it is put down or removed and the work of a changing tension.
    Returns a status code.  ``st`` holds u^n, u^(n-1) and the contact state on entry and on exit.
    Allocates the block's scratch (``Work``) and hands over to ``_advance``, which is compiled
    without reference counting and so may not allocate (config.JIT_NO_NRT).
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
        fchi=np.zeros(nslot), fbeta=np.zeros(nslot), fcol=np.full(nslot, -1, np.int64),
        rd=np.empty(ncap), ra=np.empty((ncap, ncap)))
    return _advance(c, geo, ctl, st, w, step0, nsteps, out, diag, e_h, e_q, e_p)


@njit(**JIT_STEP)
def _advance(c, geo, ctl, st, w, step0, nsteps, out, diag, e_h, e_q, e_p):
    """``step_block``'s loop (the general path, which hands quiet and held steps to their runs),
    on the scratch ``w`` that step_block allocated; returns the status."""
    U0, U1, UF, Q = st.u, st.u1, st.uf, st.q
    psi, gprev_b, gprev_f, has_gprev = st.psi, st.gprev_b, st.gprev_f, st.has_gprev
    fret_active, f_state, f_w, f_w1, f_psi, f_bprev = (
        st.fret_active, st.f_state, st.f_w, st.f_w1, st.f_psi, st.f_bprev)
    board = geo.board
    fret_p, fret_w0, fret_w1, fret_m0 = geo.fret_p, geo.fret_w0, geo.fret_w1, geo.fret_m0
    pl_start, pl_len, pl_amp, pl_p, pl_w0, pl_w1 = (
        ctl.pl_start, ctl.pl_len, ctl.pl_amp, ctl.pl_p, ctl.pl_w0, ctl.pl_w1)
    fs_on, fs_rel, fs_x0, fs_x1, fs_ms, fs_me, fs_force, fs_v0, fs_gap = (
        ctl.fs_on, ctl.fs_rel, ctl.fs_x0, ctl.fs_x1, ctl.fs_ms, ctl.fs_me, ctl.fs_force,
        ctl.fs_v0, ctl.fs_gap)
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
    scr, du, wfree, fext, fp, fw0, fw1, fchi, fbeta, fcol = (
        w.scr, w.du, w.wfree, w.fext, w.fp, w.fw0, w.fw1, w.fchi, w.fbeta, w.fcol)
    lam_f = k * k / c.fg_mass
    tb_n = ctl.tb_step.shape[0]
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
    # samples are identical (``Geo.quiet`` False, from ``skip_contacts=False``, never takes it;
    # test_skips.py compares).  With diagnostics every step takes the general path.
    out_p, out_w0, out_w1 = geo.out_p, geo.out_w0, geo.out_w1
    tb_step, tb_ratio = ctl.tb_step, ctl.tb_ratio
    quiet_end = -1  # steps before this may be quiet (what acts on the string allows it)
    stale = not diag  # quiet_end is recomputed, after a general step, only if no contact acted
    s_last = st.s_last[0]  # S of the previous step's u^n
    free = geo.quiet and st.s_last[1] != 0.0  # no contact acted in the last step (a guess)
    held = geo.held and st.s_last[2] != 0.0  # the next step may be held (``_held_run``)
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
        U0[0] = -U0[2]
        U0[n + 2] = -U0[n]
        if tb_n > 0:
            ratio, b0, b1 = _bent_stencil(c, tb_step, tb_ratio, step)
        # ---- a) linear update (+ KC vector, + S and the counts of nodes near a contact) ------
        qq = 0.0
        quf = 0.0
        qu1 = 0.0
        if c.kc > 0.0:
            qq, quf, qu1, s_last, below, close = _linear_pass_kc(c, geo, b0, b1, U0, U1, UF, Q)
        else:
            s_last, below, close = _linear_pass(c, geo, b0, b1, U0, U1, UF)
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
            eta = fw0[s] * U0[p_] + fw1[s] * U0[p_ + 1] - f_w[s]
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
            wfree[s] = 2.0 * f_w[s] - f_w1[s] + lam_f * fext[s]
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
        if c.board_k > 0.0 and (below > 0 or psi[0] != 0.0):
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
            eta = fw0[s] * U0[p_] + fw1[s] * U0[p_ + 1] - f_w[s]
            eta1 = fw0[s] * U1[p_] + fw1[s] * U1[p_ + 1] - f_w1[s]
            etaf = fw0[s] * UF[p_] + fw1[s] * UF[p_ + 1] - wfree[s]
            contact = eta > 0.0
            if contact:
                ea = eta if c.fg_alpha == 1.0 else eta**c.fg_alpha  # pow() is slow
                vpot = c.fg_k / (c.fg_alpha + 1.0) * ea * eta
                bt = c.fg_k * ea / math.sqrt(2.0 * vpot + EPS)
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
            cf = 0.25 * bt * bt + fchi[s] * c.fg_r / (2.0 * k)
            kind[nc] = FINGER
            cslot[nc] = s
            ca[nc] = bt * f_psi[s] - cf * eta1
            cc[nc] = cf
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
        # within FRET_MARGIN of a fret tip (``near``), a fret is active, or a finger touches.
        rigid = c.fret_mode == 1 and (close > 0 or nc > (1 if c.kc > 0.0 else 0))
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
                add = _fret_hit(c.kc > 0.0, UF, du, Q, fret_p, fret_w0, fret_w1, fret_m0,
                                fret_active, lam * xk)
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
                                cs, cbt, ccon, psi, f_psi, fbeta, fchi, c.fg_r / (2.0 * k), nc):
                break
        # no contact acted (the Kirchhoff-Carrier column at most): the next step may be quiet
        free = geo.quiet and below == 0 and nc == (1 if c.kc > 0.0 else 0)
        # a finger in contact held the string, alone or with rigid frets: the next step may be held
        nk = 1 if c.kc > 0.0 else 0
        held = (geo.held and joint and c.fret_mode != 2 and status == OK
                and nbase == nk + 1 and kind[nk] == FINGER and ccon[nk])
        # ---- apply the multipliers: z^(n+1) = z_free + Lambda sum_c v_c x_c ----------------------
        xk = 0.0
        for ci in range(nc):
            if kind[ci] == KC:
                xk = x[ci]
                continue
            for e in range(cstart[ci], cstart[ci + 1]):
                UF[cidx[e]] += lam * cval[e] * x[ci]
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
            etan = fw0[s] * UF[p_] + fw1[s] * UF[p_ + 1] - wn
            if ci >= 0:
                deta = etan - v1[ci]
                f_psi[s] += 0.5 * fbeta[s] * deta
                if diag:
                    dr = deta / (2.0 * k)
                    qloss += fchi[s] * c.fg_r * dr * dr * k
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


@njit(**JIT_INLINE)
def _bent_stencil(c, tb_step, tb_ratio, step):
    """Bends and vibrato: T^n = T0 * ratio(step) enters B of eq. (50a); returns (ratio, b0, b1)."""
    ratio = _tension_ratio(tb_step, tb_ratio, step)
    dl = (ratio - 1.0) * c.lam2
    return ratio, c.b0 - 2.0 * dl / c.den, c.b1 + dl / c.den


@njit(**JIT_INLINE)
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


@njit(**JIT_NO_NRT)
def _restore(U0, U1, UF, r):
    """After r (1 or 2) rotations, the caller's (u, u1, uf) hold (u^n, ...) in a rotated order."""
    # the caller's arrays, in order (a, b, c), started as (u^n, u^(n-1), scratch).  After one
    # rotation the local U0 is the caller's c, U1 the caller's a; after two, U0 = b, U1 = c.
    # node by node, in place (no allocation: see JIT_NO_NRT)
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


@njit(**JIT_INLINE)
def _finger_x(x0, x1, ms, me, step):
    """Finger position x / L... in metres: x0 until step ms, gliding linearly to x1 at step me."""
    if me <= ms:
        return x0 if step < ms else x1
    if step <= ms:
        return x0
    if step >= me:
        return x1
    return x0 + (x1 - x0) * (step - ms) / (me - ms)


@njit(**JIT_INLINE)
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


@njit(**JIT_INLINE)
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


@njit(**JIT_INLINE)
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


@njit(**JIT_INLINE)
def _joint_gamma(nbase, kind, cslot, cstart, cval, ca, cc, vfree, v1, x, G, cgam, cs, cbt, ccon,
                 psi, f_psi, fbeta, fchi, rdamp, nc):
    """The gradient correction of sec. 4.7 for columns that act together; True if any changed.

    ``_gamma`` predicts a column's psi from the free motion and its own force alone.  When a finger
    presses the string onto the fretboard, or two fingers share nodes, that prediction leaves out
    the other forces and can be badly wrong (the board's column dropped while the finger drives the
    string through it).  With the joint rule, contact columns enter the first solve with gamma = 1;
    here each one's predicted mean psi is read off that joint solution, and where it would pull
    (mean < 0 in contact) or leave a residual (out of contact), gamma is recomputed by the same
    rule with the prediction that includes every other column's force from the first solve.  The
    caller then solves once more.  Any gamma keeps the energy balance exact.
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
            cf = 0.25 * bt * bt + fchi[s_] * rdamp
            cc[i] = cf
            ca[i] = bt * ps - cf * v1[i]
        else:
            f = gnew / gold
            for e in range(cstart[i], cstart[i + 1]):
                cval[e] *= f
            vfree[i] *= f
            v1[i] *= f
            ca[i] = ps - 0.25 * v1[i]
    return changed


@njit(**JIT_INLINE)
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
    vfree[nc] = fret_w0[q] * UF[p_] + fret_w1[q] * UF[p_ + 1]
    v1[nc] = fret_w0[q] * U1[p_] + fret_w1[q] * U1[p_ + 1]
    cstart[nc + 1] = nent + 2
    return nent + 2


@njit(**JIT_INLINE)
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


@njit(**JIT_INLINE)
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


@njit(**JIT_INLINE)
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


@njit(**JIT_INLINE)
def _scatter(nc, kind, cstart, cidx, cval, x, lam, du):
    """du = Lambda * sum of the sparse columns' forces; returns the KC multiplier."""
    xk = 0.0
    for ci in range(nc):
        if kind[ci] == KC:
            xk = x[ci]
            continue
        for e in range(cstart[ci], cstart[ci + 1]):
            du[cidx[e]] += lam * cval[e] * x[ci]
    return xk


@njit(**JIT_INLINE)
def _unscatter(nc, cstart, cidx, du):
    for e in range(cstart[0], cstart[nc]):
        du[cidx[e]] = 0.0


@njit(**JIT_NO_NRT)
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


@njit(**JIT)
def fir_decimate(buf, rtaps, start, factor, nnew):
    """y[m] = sum_i rtaps[i] buf[j + i] for the new inputs j = start, start + factor, ... (buf
    holds len(rtaps) - 1 samples of history before the nnew new ones; rtaps is time-reversed)."""
    nt = rtaps.shape[0]
    count = 0 if start >= nnew else (nnew - 1 - start) // factor + 1
    out = np.empty(count)
    for m in range(count):
        j = start + m * factor
        acc = 0.0
        for i in range(nt):
            acc += rtaps[i] * buf[j + i]
        out[m] = acc
    return out
