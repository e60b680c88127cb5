"""What the kernels of one string share: the column kinds and finger states they switch on, the
per-string constants of the scheme (``Coefs``, built by ``engine.fd.string``), the geometry of its
contacts (``Geo``), the controls its events become (``Controls``, ``engine.fd.controls``), the state
carried from block to block (``State``) and the general step's scratch (``Work``): type-stable
NamedTuples of floats and arrays.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

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
    """Per-string constants of the scheme (all SI); built by ``engine.fd.string``."""

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
    fg_r: float  # finger contact damping, N s / m (the preset's: ``Controls.fs_r``)
    fg_lift: float  # finger is removed once this far above the string, m
    lam2: float  # T0 k^2 / (rho A h^2): the tension's share of B, for bends
    den: float  # 1 + sigma0 k
    gamma_rule: int = GAMMA_JOINT  # sec. 4.7 variant, see ``_gamma`` (a knob of the accuracy study)
    # quiet steps leave the Kirchhoff-Carrier column out while S (``_pass_kc``) of the step
    # before is below this: its tension rise E A S / (2 L h) is then below a stated share of T0
    # (``string.kc_skip_level``); 0 keeps it in every step
    kc_s_skip: float = 0.0


class Geo(NamedTuple):
    """Static geometry on the grid: fretboard, frets, pickups (built by ``engine.fd.string``).

    The rigid constraints are the frets, then (a rigid fretboard) one per node over the board:
    the fret arrays hold both, the first ``nfret`` entries the frets, each further one a node p
    with weights (1, 0) and m0 the board's height there.  The kernels treat them alike, except
    that the active-set check looks at the board's nodes only while one is within reach."""

    board: np.ndarray  # b at nodes 1..N-1 (array index = node - 1)
    near: np.ndarray  # per node: level below which a rigid fret may be reached this step
    fret_p: np.ndarray  # per rigid constraint: padded index of the interpolant's left node
    fret_w0: np.ndarray
    fret_w1: np.ndarray
    fret_m0: np.ndarray  # fret tip heights m0 (<= 0), then the rigid board's heights
    out_p: np.ndarray  # per pickup: interpolant
    out_w0: np.ndarray
    out_w1: np.ndarray
    # per node: the level the linear pass counts nodes below (``below``): the board itself under
    # a Hertzian board (below it is contact), the board plus the contact margin under a rigid one
    # (below it, the board may be reached this step)
    bnear: np.ndarray
    nfret: int  # the frets among the rigid constraints (the rest are the board's nodes)


class Policy(NamedTuple):
    """Which specialised loops a render may take (``RenderOptions``); the samples are the same
    either way (``tests/engine/test_skips.py``, ``tests/engine/test_held.py``)."""

    # False: every step takes the general path (``RenderOptions.skip_contacts=False``)
    quiet: bool = True
    # False: the steps of a held note take the general path too (``RenderOptions.held_steps``)
    held: bool = True


class Controls(NamedTuple):
    """What the player does, as step-indexed arrays (built by ``engine.fd.controls``)."""

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
    # contact damping R (N s/m) of a finger held from step fs_rs on (``engine.fd.intonation``
    # calibrates it per fret); before that step, while it lands, ``Coefs.fg_r``
    fs_r: np.ndarray
    fs_rs: np.ndarray
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
    # [S of u^(n-1) (``_pass_kc``), 1.0 if no contact acted in the last step, 1.0 if the
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
    xp: np.ndarray  # the rigid frets' last feasible multipliers (``step._advance``'s active set)
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
    fr: np.ndarray  # its contact damping R in this step (``Controls.fs_r``)
    fbeta: np.ndarray
    fcol: np.ndarray  # the finger's column (-1: none)
    rd: np.ndarray  # ``_ray_blocked``'s direction and system
    ra: np.ndarray
