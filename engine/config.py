"""The one place for numba flags (STUMPY-style): every kernel is compiled with ``JIT``.

* ``cache``: compiled kernels are written next to the source (or to ``NUMBA_CACHE_DIR``), so a worker
  process that starts later loads them instead of compiling.
* ``nogil``: kernels release the GIL, so strings can be stepped from threads.
* ``fastmath``: only re-association and contraction (FMA), which let LLVM vectorise the stencil's
  reductions.  No ``nnan``/``ninf``: the kernels must be able to see a non-finite value and report it.
  Results stay deterministic for a given machine, so block and one-shot renders are bit-identical.
  The step loops are compiled without them (``JIT_STEP``).  ``GUITAR_NUMBA_FASTMATH=0`` compiles
  every kernel without them.
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
    "forceinline": False,
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


# The step loops (the general path ``_advance``, the quiet run, the held run, and ``_contact``,
# which decides for the quiet run what the general path decides in its own code) are compiled
# without fastmath: the quiet and held runs repeat the general path's arithmetic in loops of
# their own, and with re-association or contraction allowed LLVM rounded each copy its own way
# (with these flags, 2 of 204 random scenes with held steps came out bit-identical with held
# steps on and off; without them, all: ``tools/held_soak.py``).  Everything the loops
# inline is compiled with the loop's flags; the one hot loop that needs fastmath to vectorise,
# the linear pass with its float sums, is a kernel of its own (``kernels._pass_kc``) that all
# three call.  Quiet and held steps are thus bit-identical to the general path by construction.
JIT_STEP = {**JIT, "fastmath": set()}

JIT_HELPER = {**JIT_STEP, "forceinline": True}
