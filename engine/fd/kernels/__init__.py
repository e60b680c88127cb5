"""The time-step loop of one string: the DAFx24 scheme (Bilbao, Russo, Webb & Ducceschi 2024), sec. 4.

One step n -> n+1, in the order of the paper's sec. 5 breakdown:

a) linear update u_free = B u^n + C u^(n-1) + E f^n            eqs. (36), (50a-c)
   fused with q = D u^n and its dot products for the Kirchhoff-Carrier column    eqs. (37), (52)
   and with the counts of nodes near the fretboard and the frets (is a contact possible at all?)
b) the excitation f_e^n of eq. (5), spread by its interpolant                    eqs. (4), (19)
c) fretboard: SAV gradient g_B from eq. (54)-(55a), gradient correction gamma      sec. 4.7
   (the Hertzian board), or one rigid constraint per node, in the frets' active set
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
reaction does non-positive work, which the energy balance books as a loss (exactly).  A rigid
fretboard is more of the same constraints, one per node over the board (j_q = e_p, m0_q = b_p).

Indexing: a string of N intervals has interior nodes 1..N-1.  Arrays ``U`` hold them with two ghost
cells each side: node i lives at U[i+1]; U[1] = U[N+1] = 0 are the fixed ends and U[0] = -U[2],
U[N+2] = -U[N] make D^2 the square of the Dirichlet D (simply supported ends, eq. (2)).  Loops run
over non-negative offsets (U[j], U[j+1] ... U[j+4]) so that LLVM vectorises them.

The modules, low to high (each opens with the equations it implements):

* ``data``        constants, ``Coefs``, ``Geo``, ``Controls``, ``State``, ``Work``
* ``linear``      the string's linear update and Kirchhoff-Carrier column, a); the interpolant; pickups
* ``excitation``  the pluck force, b)
* ``collisions``  fretboard and frets (penalty and rigid), c) and d)
* ``finger``      the finger's contact and update, d)
* ``sav``         the gradient correction of sec. 4.7
* ``system``      the small system and its solves, f)
* ``energy``      H, Q and P of eqs. (42)-(46)
* ``runs``        quiet and held steps
* ``step``        ``step_block``: the time-step loop and its general path

Everything they define is importable from ``engine.fd.kernels``, where the rest of the engine,
the tests and the benchmarks look it up.
"""

from ...config import _ENTRIES, _type_key, entry_point  # noqa: F401
from .collisions import (  # noqa: F401
    _add_rigid,
    _contact,
    _fret_hit,
    _remove_col,
    _rigid_row,
    _sav_board,
    _sav_frets,
)
from .data import (  # noqa: F401
    ACTIVE,
    BOARD,
    DAMPER,
    EPS,
    FINGER,
    FRETPEN,
    GAMMA_JOINT,
    GAMMA_NONE,
    GAMMA_OWN,
    GAMMA_PAPER,
    GONE,
    IDLE,
    KC,
    NONFINITE,
    OK,
    RIGID,
    Coefs,
    Controls,
    Geo,
    Policy,
    State,
    Work,
)
from .energy import _energy, _step_energy  # noqa: F401
from .excitation import _pluck_force, _pluck_forces  # noqa: F401
from .finger import _beta, _eta, _finger_row, _finger_x, _w_free  # noqa: F401
from .linear import (  # noqa: F401
    _add_kc,
    _bent_stencil,
    _counted,
    _ends,
    _kc_multiplier,
    _pass,
    _pass_kc,
    _pickups,
    _q_index,
    _tension_ratio,
    interp,
)
from .runs import _held_run, _held_until, _quiet_run, _quiet_until  # noqa: F401
from .sav import _apply_gamma, _gamma, _joint_gamma  # noqa: F401
from .step import _advance, _restore, step_block  # noqa: F401
from .system import (  # noqa: F401
    _assemble,
    _gram,
    _gram_kc,
    _is_arrow,
    _ray_blocked,
    _scatter,
    _solve,
    _solve_arrow,
    _solve_n,
    _solve_sized,
    _step_to_zero,
    _unscatter,
)
