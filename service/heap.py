"""The heaps of the server's processes: glibc's malloc, and what Python's garbage collector walks.

glibc keeps freed memory in its heaps for reuse, and serves a large block from a mapping of its
own only above a threshold that rises with the largest such block freed so far (up to 32 MiB).
A process that handles blocks of every size (a small scene's answer, a 96 kHz song's bytes) ends
up with its large blocks in the heaps too, and with free holes between live blocks that nothing
returns to the system: resident memory creeps up under a mixed load
(``benchmarks.mixed_load`` prints every process's, minute by minute).

- a render worker hands back the pages a job freed after every job (``trim``): its jobs' arrays
  are large and freed together, and mapping each of them on its own would cost render speed;
- the API process fixes the threshold (``map_large_blocks``, setting
  ``GUITAR_API_MMAP_THRESHOLD_KIB``): its large blocks are request and response bodies, each mapped
  and unmapped on its own, and a trim cannot release a heap whose holes lie between live blocks.

On a C library other than glibc both do nothing: that allocator returns memory its own way.

- a worker, render or live, freezes what its warm-up made out of the garbage collector's sight
  (``freeze_warm_up``) before it says it is ready.
"""

from __future__ import annotations

import ctypes
import gc
from typing import Any

_M_MMAP_THRESHOLD = -3  # mallopt's parameter number (glibc's malloc.h)
MAX_MMAP_THRESHOLD = 32 * 1024 * 1024  # glibc's ceiling on 64-bit systems (HEAP_MAX_SIZE / 2)


def _glibc() -> Any:
    try:
        libc = ctypes.CDLL("libc.so.6")
        for name in ("malloc_trim", "mallopt"):  # glibc's own: both or neither
            getattr(libc, name)
    except (OSError, AttributeError):
        return None
    return libc


_LIBC = _glibc()


def trim() -> None:
    """Return to the system every free page of every heap of this process (``malloc_trim(0)``:
    a fraction of a millisecond after a render job, ``benchmarks.worker_memory`` prints it)."""
    if _LIBC is not None:
        _LIBC.malloc_trim(0)


def map_large_blocks(threshold: int) -> bool:
    """From now on serve every block of at least ``threshold`` bytes from a mapping of its own,
    unmapped when it is freed, whatever this process freed before (``mallopt(M_MMAP_THRESHOLD)``,
    which also stops glibc raising the threshold).  True when the C library took it."""
    if _LIBC is None or not 0 < threshold <= MAX_MMAP_THRESHOLD:
        return False
    return bool(_LIBC.mallopt(_M_MMAP_THRESHOLD, threshold))


def available() -> bool:
    return _LIBC is not None


def freeze_warm_up() -> int:
    """Freeze what this process holds now (modules, kernels, prepared guitars, the labels'
    libraries) out of the garbage collector's sight, and say how many objects that was.  They live
    as long as the process, and every full collection that later allocations trigger would walk
    them all again: tens of milliseconds in a warmed worker (``python -m benchmarks.gc_pause``),
    in the time of the render under way or on a live worker's audio thread, whose blocks are due
    20 ms before they play."""
    gc.collect()
    gc.freeze()
    return gc.get_freeze_count()
