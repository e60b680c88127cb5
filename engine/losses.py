"""A string's losses: the coefficients sigma_0, sigma_1 of the damping model
sigma_0 + sigma_1 beta^2 (beta the wavenumber) fitted to the preset's two decay times, T60 at the
fundamental and at 2 kHz.  Both models read them (the finite-difference scheme's loss terms, the
waveguide's loop filter) and so does the cost estimate; plain arithmetic, no numerics library.
"""

from __future__ import annotations

import math

from .presets import StringSpec

# 60 dB of amplitude: exp(-sigma T60) = 1e-3, so sigma = 3 ln(10) / T60.  (Bilbao 2009 writes
# 6 ln(10) / T60; measured on rendered audio that halves the decay time: tests/engine/test_string.py)
LN1000 = 3.0 * math.log(10.0)


def loss_coefficients(spec: StringSpec, tension: float) -> tuple[float, float]:
    """sigma_0, sigma_1 matching T60 at the fundamental and at 2 kHz (two-frequency calibration)."""
    rho_a = spec.linear_density_kg_m
    gamma2 = tension / rho_a
    kappa2 = spec.bending_stiffness_nm2 / rho_a

    def xi(f: float) -> float:  # beta^2 of the mode at frequency f (continuous dispersion)
        w = 2.0 * math.pi * f
        return (-gamma2 + math.sqrt(gamma2**2 + 4.0 * kappa2 * w * w)) / (2.0 * kappa2)

    f1, f2 = spec.frequency_hz, 2000.0
    x1, x2 = xi(f1), xi(f2)
    t1, t2 = spec.t60_fundamental_s, spec.t60_2khz_s
    sigma1 = LN1000 * (1.0 / t2 - 1.0 / t1) / (x2 - x1)
    sigma1 = max(sigma1, 0.0)
    sigma0 = max(LN1000 / t1 - sigma1 * x1, 0.0)
    return sigma0, sigma1
