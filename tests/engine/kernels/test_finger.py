"""engine.fd.kernels.finger: the finger's SAV gradient is that of sqrt(2 V), its free update is
Newton's law, and a slide glides linearly."""

import math
from typing import NamedTuple

import numpy as np
import pytest

from engine.fd.kernels import EPS, _beta, _eta, _finger_x, _w_free


class _Finger(NamedTuple):
    fg_alpha: float
    fg_k: float


@pytest.mark.parametrize("alpha", [1.0, 1.5, 2.3])
def test_beta_is_the_gradient_of_sqrt_2v(alpha):
    """Eq. (55c): beta = V'(eta) / sqrt(2 V + eps), the derivative of psi = sqrt(2 V) (eps aside),
    for V = K eta^(alpha + 1) / (alpha + 1)."""
    c = _Finger(alpha, 2.0e4)
    for eta in (1e-6, 3e-5, 2e-4):
        def psi(e):
            return math.sqrt(2.0 * c.fg_k * e ** (alpha + 1.0) / (alpha + 1.0) + EPS)

        d = 1e-4 * eta
        slope = (psi(eta + d) - psi(eta - d)) / (2.0 * d)
        assert _beta(c, eta) == pytest.approx(slope, rel=1e-6)


def test_free_finger_keeps_its_velocity_and_a_force_accelerates_it():
    """Eq. (39): w_free = 2 w^n - w^(n-1) + (k^2 / M) f, a centred second difference of Newton's
    M w'' = f."""
    k, mass = 1.0 / 44100.0, 5e-3
    lam_f = k * k / mass
    w, w1 = 1e-3, 1.2e-3  # moving towards the board at 0.2 mm per step
    assert _w_free(w, w1, lam_f, 0.0) - w == pytest.approx(w - w1, rel=1e-9)  # the same step
    force = -3.0
    accel = (_w_free(w, w1, lam_f, force) - 2.0 * w + w1) / (k * k)
    assert accel == pytest.approx(force / mass, rel=1e-9)


def test_eta_is_the_interpolated_string_past_the_fingertip():
    """On a straight string (u = 1e-3 x / h here) the interpolant reads the line itself: a quarter
    of the way from padded node 2 to node 3 the string is at 1.25e-3."""
    u = np.arange(5) * 1e-3 - 1e-3
    assert _eta(0.75, 0.25, 2, u, 1.1e-3) == pytest.approx(1.25e-3 - 1.1e-3, rel=1e-12)
    assert _eta(0.75, 0.25, 2, u, 2e-3) < 0.0  # the fingertip above the string: no contact


def test_a_slide_glides_linearly_between_its_steps():
    x0, x1, ms, me = 0.10, 0.20, 100, 300
    assert _finger_x(x0, x1, ms, me, 0) == x0
    assert _finger_x(x0, x1, ms, me, ms) == x0
    assert _finger_x(x0, x1, ms, me, 200) == pytest.approx(0.15)
    assert _finger_x(x0, x1, ms, me, me) == x1
    assert _finger_x(x0, x1, ms, me, 10**6) == x1
    # a jump (no glide) moves at ms
    assert _finger_x(x0, x1, ms, ms, ms - 1) == x0
    assert _finger_x(x0, x1, ms, ms, ms) == x1
