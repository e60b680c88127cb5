"""The scheme's stability bound and smallest grid: plain arithmetic on a string's physical
parameters, with no numerics library, so that the schema layer's cost estimate (``engine.cost``)
can size a string's grid in a process that never loads the kernels.  ``engine.fd.string`` builds
the grids with them."""

from __future__ import annotations

import math

MIN_NODES = 4  # the fewest intervals a string's grid may have (``string.tune``)


def h_min(k: float, tension: float, rho_a: float, ei: float, sigma1: float) -> float:
    """The stability bound of eq. (47)."""
    a = tension * k / rho_a + 4.0 * sigma1
    return math.sqrt(0.5 * k * (a + math.sqrt(a * a + 16.0 * ei / rho_a)))
