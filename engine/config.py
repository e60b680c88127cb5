"""The one place for numba flags (STUMPY-style): every kernel is compiled with ``JIT``.

* ``cache``: compiled kernels are written next to the source (or to ``NUMBA_CACHE_DIR``), so a worker
  process that starts later loads them instead of compiling.
* ``nogil``: kernels release the GIL, so strings can be stepped from threads.
* ``fastmath``: only re-association and contraction (FMA), which let LLVM vectorise the stencil's
  reductions.  No ``nnan``/``ninf``: the kernels must be able to see a non-finite value and report it.
  Results stay deterministic for a given machine, so block and one-shot renders are bit-identical,
  as long as the kernels are loaded from numba's cache: the process that compiles a kernel with
  fastmath runs code that rounds otherwise than the object code it caches (``tools.render_digest
  --first-process``), which is why ``engine.precompile`` compiles in a child process.
  The step loops are compiled without them (``JIT_STEP``).  ``GUITAR_NUMBA_FASTMATH=0`` compiles
  every kernel without them.

``entry_point`` calls a compiled kernel without numba's dispatcher (both models' voices use it).

Importing this module also spares every process numba's BLAS probe (``_SkipBlasProbe``).
"""

from __future__ import annotations

import importlib.abc
import os
import sys

import numpy as np

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

# ``forceinline`` is set in every dict: numba hands a flag that a function does not set down to the
# functions compiled for its calls, so a kernel first compiled from an inlined helper would be
# inlined too (the linear pass must stay one compiled kernel: see ``JIT_STEP``).

# IR-level inlining (numba's ``inline="always"``), for the waveguide's kernels.  The string's step
# loops do not use it (``JIT_HELPER``).
JIT_INLINE = {**JIT, "inline": "always"}

# The step loops (the general path ``_advance``, the quiet run, the held run, and ``_contact``,
# which decides for the quiet run what the general path decides in its own code) are compiled
# without fastmath: the quiet and held runs repeat the general path's arithmetic in loops of
# their own, and with re-association or contraction allowed LLVM rounded each copy its own way
# (with these flags, 2 of 204 random scenes with held steps came out bit-identical with held
# steps on and off; without them, all: ``tools/held_soak.py``).  The helpers the loops call are
# compiled without them too (``JIT_HELPER``); the one hot loop that needs fastmath to vectorise,
# the linear pass with its float sums, is a kernel of its own (``kernels._pass_kc``, not inlined)
# that all three call.  Quiet and held steps are thus bit-identical to the general path by
# construction.
JIT_STEP = {**JIT, "fastmath": set()}

# The helpers of the step loops (``_eta``, ``_gram``, ``_solve``, ``_pickups``, ...): ordinary
# compiled functions that LLVM always inlines (numba's ``forceinline``), compiled like the loops.
# The loops run with numba's reference counting (NRT), which counts an array's references up and
# down with an atomic read-modify-write (``lock xadd`` on x86) wherever a variable that holds it
# is bound and dies, and prunes the pairs it can prove redundant.  Three rules keep the counts out of
# the quiet and held runs' loops (read off the LLVM IR: ``dispatcher.inspect_llvm()``, calls of
# ``NRT_incref``; the general path's loop keeps some on its branches, around the runs' calls, the
# rigid frets' active set and the diagnostics):
# * helpers are inlined by LLVM, not at numba's IR level: IR-inlining copies each parameter into a
#   variable of the loop that is bound and dies in every step, and the pruner paired few of those
#   counts (with numba 0.68.1, 31 counts up and 65 down stayed in the held run's loop);
# * the loops take the arrays out of the NamedTuples once, before the loop, and pass arrays, not
#   NamedTuples of arrays (``Geo``), to the helpers they call in every step: a NamedTuple counts
#   every array it holds;
# * a helper that takes arrays calls no kernel that is not inlined (the linear pass, ``_contact``):
#   numba's check of such a call's status leaves the helper by a path without the counts down,
#   and the pruner keeps every pair on such a path.  The loops call those kernels themselves
#   (``_step_energy``, which calls ``_energy``, still counts: only with diagnostics).
# * the frets' active-set check (``_fret_hit``), called in every held step and in the general
#   path's and the quiet run's contact tests, takes its eight arrays as borrowed views
#   (``kernels.collisions._borrowed``: the same array with no reference, its meminfo null), so
#   that the counts its inlined body makes are on nothing: numba's pruner left a pair per array
#   in the held run's loop, atomic operations in every step (``tools.compare``: 0.86-0.90 of
#   the time on its fretted scenes without them, the same samples).
# The kernels the loops call without inlining (the linear pass, the quiet and held runs, ...) take
# their arrays from the loop, whose own variables are counted only around the loop.
JIT_HELPER = {**JIT_STEP, "forceinline": True}

# Fret calibrations kept on disk across processes (``engine.calibration_store``): under
# ``GUITAR_CACHE_DIR`` (default ``$XDG_CACHE_HOME/guitar-synth``, else ``~/.cache/guitar-synth``);
# ``GUITAR_CALIBRATION_CACHE=0`` keeps them in memory only.
CACHE_DIR = os.environ.get("GUITAR_CACHE_DIR") or os.path.join(
    os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"),
    "guitar-synth")
CALIBRATION_CACHE = os.environ.get("GUITAR_CALIBRATION_CACHE", "1") != "0"


# ---- numba's start-up -------------------------------------------------------------------------

class _SkipBlasProbe(importlib.abc.MetaPathFinder):
    """Refuses ``scipy.linalg`` to numba's BLAS probe, and to nothing else.

    The first kernel a process compiles or loads makes numba import its lowering registries, and one
    of them (``numba.np.arraymath``, as of numba 0.68) imports ``scipy.linalg.cython_blas`` at
    import time only to choose how ``np.convolve`` and ``np.correlate`` take their inner products (a
    BLAS dot, or a loop when the import fails).  ``scipy.linalg`` pulls in numpy's f2py and testing
    packages and starts OpenBLAS's threads: 0.09-0.10 s of CPU in every process that renders, pinned
    to one core (each CLI render, service worker and batch worker; ``python -m tools.startup``), and
    none of the kernels calls either function.  So while that module is being imported (it is in
    ``sys.modules`` but has not yet set ``_HAVE_BLAS``), the import of ``scipy.linalg`` fails here,
    numba takes the loop, and the kernels render the same samples (``tools.render_digest``: kernels
    compiled with the probe and without).  ``GUITAR_NUMBA_BLAS_PROBE=1`` leaves the probe to numba.
    Any other import of ``scipy.linalg``, before or after, is untouched (numba's own linear algebra
    imports it again when it compiles a call).  Should numba rename either, this finder refuses
    nothing, and the process pays the probe again: ``tests/engine/test_startup.py`` says so."""

    def find_spec(self, name, path=None, target=None):
        if name == "scipy.linalg":
            arraymath = sys.modules.get("numba.np.arraymath")
            if arraymath is not None and not hasattr(arraymath, "_HAVE_BLAS"):
                raise ImportError("scipy.linalg is not imported for numba's BLAS probe "
                                  "(engine.config._SkipBlasProbe)")
        return None


if os.environ.get("GUITAR_NUMBA_BLAS_PROBE", "0") != "1" and not any(
        isinstance(f, _SkipBlasProbe) for f in sys.meta_path):
    sys.meta_path.insert(0, _SkipBlasProbe())


# ---- calling a compiled kernel ----------------------------------------------------------------

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
    with numpy's bounds checks (``tests/engine/kernels/test_step.py`` renders that way)."""
    if not hasattr(dispatcher, "compile"):  # NUMBA_DISABLE_JIT=1: a plain Python function
        return dispatcher
    key = (dispatcher, _type_key(args))
    fn = _ENTRIES.get(key)
    if fn is None:
        fn = dispatcher.compile(tuple(dispatcher.typeof_pyval(a) for a in args))
        _ENTRIES[key] = fn
    return fn
