"""engine.fd.kernels.system: the small solve against numpy's, which systems take the arrowhead solve,
and singular systems reported."""

import numpy as np

from engine.fd import kernels


def _system(n, rng, zero_lead=False):
    a = rng.standard_normal((n, n)) + n * np.eye(n)
    if zero_lead:  # the first pivot must come from another row
        a[0, 0] = 0.0
    return a, rng.standard_normal(n)


def test_small_solve_matches_numpy_with_and_without_pivoting():
    rng = np.random.default_rng(7)
    for n in range(1, 7):
        for zero_lead in (False, True):
            if n == 1 and zero_lead:
                continue
            for _ in range(50):
                a, r = _system(n, rng, zero_lead)
                big = np.zeros((8, 8))  # the kernel's matrices are larger than the system
                big[:n, :n] = a
                x = np.zeros(8)
                x[:n] = r
                assert kernels._solve(big, x, n)
                want = np.linalg.solve(a, r)
                assert np.allclose(x[:n], want, rtol=1e-12, atol=1e-12 * np.abs(want).max())


def _arrowhead(n, rng):
    """A system of the kernel's kind: symmetric positive definite with every row but the first
    coupled only to the first, then each row scaled by a positive number (a column's c)."""
    h = np.diag(rng.uniform(0.5, 2.0, n))
    h[0, 1:] = h[1:, 0] = rng.standard_normal(n - 1) * 0.3
    h[0, 0] += np.sum(h[0, 1:] ** 2 / np.diag(h)[1:])  # keeps the Schur complement > 0
    return rng.uniform(0.1, 1e3, n)[:, None] * h, rng.standard_normal(n)


def test_arrowhead_systems_are_recognised_and_solved_without_pivoting():
    rng = np.random.default_rng(11)
    for n in range(2, 7):
        for _ in range(50):
            a, r = _arrowhead(n, rng)
            big = np.zeros((8, 8))
            big[:n, :n] = a
            assert kernels._is_arrow(big, n)
            x = np.zeros(8)
            x[:n] = r
            assert kernels._solve(big, x, n)
            want = np.linalg.solve(a, r)
            assert np.allclose(x[:n], want, rtol=1e-12, atol=1e-12 * np.abs(want).max())


def test_systems_that_are_not_arrowheads_take_the_pivoting_solve():
    rng = np.random.default_rng(12)
    a, r = _arrowhead(4, rng)
    coupled = a.copy()
    coupled[1, 2] = coupled[2, 1] = 0.1  # two narrow columns share a node
    zero_pivot = a.copy()
    zero_pivot[2, 2] = 0.0  # solvable, but not by eliminating row 2 on its diagonal
    for m in (coupled, zero_pivot):
        assert not kernels._is_arrow(m, 4)
        x = r.copy()
        assert kernels._solve(m.copy(), x, 4)
        assert np.allclose(x, np.linalg.solve(m, r), rtol=1e-12, atol=1e-12)


def test_small_solve_reports_singular_systems():
    for n in (1, 2, 3, 4):
        a = np.ones((n, n)) if n > 1 else np.zeros((1, 1))
        assert not kernels._solve(a.copy(), np.ones(n), n)
