"""The one place for numba flags (STUMPY-style): every kernel is compiled with ``JIT``.

* ``cache``: compiled kernels are written next to the source (or to ``NUMBA_CACHE_DIR``), so a worker
  process that starts later loads them instead of compiling.
* ``nogil``: kernels release the GIL, so strings can be stepped from threads.
* ``fastmath``: only re-association and contraction (FMA), which let LLVM vectorise the stencil's
  reductions.  No ``nnan``/``ninf``: the kernels must be able to see a non-finite value and report it.
  Results stay deterministic for a given machine, so block and one-shot renders are bit-identical.
  ``GUITAR_NUMBA_FASTMATH=0`` compiles without them: where two loops do the same arithmetic in
  different code (the held steps and the general path), LLVM may re-associate each its own way,
  and only without these flags must their results agree bit for bit (``tests/engine/test_held.py``,
  ``benchmarks/held_soak.py``).
"""

from __future__ import annotations

import os

FASTMATH = (frozenset({"reassoc", "contract", "nsz"})
            if os.environ.get("GUITAR_NUMBA_FASTMATH", "1") != "0" else frozenset())

JIT = {
    "cache": os.environ.get("GUITAR_NUMBA_CACHE", "1") != "0",
    "nogil": True,
    "fastmath": set(FASTMATH),
    "error_model": "numpy",
    "boundscheck": False,
}

# Helpers that the time-step loop calls in every step are inlined into it at numba's IR level.
# A call to a compiled helper passes the NamedTuples and arrays it takes as structs and (with NRT,
# see ``JIT_NO_NRT``) counts the arrays' references: when ``_quiet_until`` (not inlined) took
# ``Controls``, a fretted string's step went from 285 to 473 ns in ``benchmarks.speed``'s
# component table.  The helpers that are not inlined and count references therefore take arrays
# and scalars, never a NamedTuple of arrays; those compiled with ``JIT_NO_NRT`` count none and may
# (``_advance`` takes step_block's and hands them on to the quiet and held runs).
JIT_INLINE = {**JIT, "inline": "always"}

# Kernels that allocate no array and return none are compiled without numba's reference counting
# (NRT): the caller owns every array they touch (``step_block`` allocates the block's scratch and
# hands over to ``_advance``).  With it, each call of an inlined helper that takes an array counted
# a reference up on the way in and down after the helper's loop, and numba's refcount pruning
# could not pair them across the loop: a held step did six such pairs (read off its LLVM IR),
# each an atomic read-modify-write (``lock xadd`` on x86) that also orders the memory operations
# around it.  A function compiled for a call from such a kernel inherits the setting, so nothing
# such a kernel calls may create an array either (numba refuses to compile an allocation without
# NRT).
JIT_NO_NRT = {**JIT, "_nrt": False}
