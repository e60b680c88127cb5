"""The decimator of an oversampled string (``engine.output.Decimator``): an FIR filter evaluated at
the output rate only, its sums in a fixed order, so that any block size gives bit-identical samples.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from ..config import JIT


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
