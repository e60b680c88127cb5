"""engine.kernels: the kept entry point is the one numba would pick; the small solve; indices."""

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

from engine import kernels
from engine.guitar import RenderOptions, prepare
from engine.scene import Scene

from .conftest import fret, pluck, scene


def _voice_args(v, nsteps=400):
    out = np.zeros((len(v.pickup_gains), nsteps))
    e = np.empty(0)
    return (v.coefs, v.geom, v.ctl.arrays, v.state, v.step, nsteps, out, False, e, e, e)


def test_type_key_tells_apart_what_typeof_tells_apart():
    a = np.zeros(12)
    ro = np.zeros(12)
    ro.flags.writeable = False
    cases = [a, a[::2], ro, np.zeros(12, np.float32), np.zeros(12, np.int64),
             np.zeros((3, 4)), np.zeros((3, 4), order="F"), np.zeros((4, 6))[:, :3],
             1, 1.0, True, (a, 1), (a, a[::2])]
    for x in cases:
        for y in cases:
            same_type = kernels.step_block.typeof_pyval(x) == kernels.step_block.typeof_pyval(y)
            assert (kernels._type_key(x) == kernels._type_key(y)) == same_type, (x, y)


def test_strings_share_one_entry_point_and_it_renders_as_the_dispatcher(monkeypatch):
    sc = Scene.model_validate(scene([fret(2, 5), pluck(2, force=8.0), pluck(5)], duration=0.01))
    eng = prepare(sc, RenderOptions(skip_decayed=False))
    a, b = eng.voices
    args_a, args_b = _voice_args(a), _voice_args(b)
    fn = kernels.entry_point(kernels.step_block, args_a)
    assert kernels.step_block.compile(
        tuple(kernels.step_block.typeof_pyval(x) for x in args_b)) is fn

    def no_typeof(_value):
        raise AssertionError("the second string resolved its argument types again")

    monkeypatch.setattr(kernels.step_block, "typeof_pyval", no_typeof)
    assert kernels.entry_point(kernels.step_block, args_b) is fn
    monkeypatch.undo()

    twin = prepare(sc, RenderOptions(skip_decayed=False)).voices[0]
    args_t = _voice_args(twin)
    assert fn(*args_a) == kernels.step_block(*args_t) == kernels.OK
    assert np.array_equal(args_a[6], args_t[6])
    assert np.any(args_a[6] != 0.0)


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


# A pluck at 0.98 L on a string of N = 9 (a D6 string on a bass scale at 22.05 kHz; the soak's
# case 1769 found this string) lies in the last grid interval: its right-hand node is the fixed
# end, with weight 0 and no q.
LAST_INTERVAL_PLUCK = {
    "duration": 0.005, "sample_rate": 22050, "quality": "draft",
    "guitar": {"preset": "bass", "strings": [{"string": 3, "radius_m": 7.19e-05, "note": "D6"}]},
    "output": {"body": "none", "normalize": False},
    "events": [{"type": "pluck", "time": 0.0, "string": 3, "position": 0.98, "force": 2.0}],
}


def test_kernels_stay_inside_their_arrays_at_the_fixed_ends():
    """The compiled kernels run without bounds checks, so a read past an array's end passes
    silently (the excitation read q one past its end here, multiplied by weight 0).  Run as
    Python (``NUMBA_DISABLE_JIT=1``), every index is checked by numpy."""
    code = ("import json, sys, numpy as np, engine\n"
            "a = engine.render(json.loads(sys.argv[1]))\n"
            "assert np.all(np.isfinite(a)) and np.abs(a).max() > 0\n")
    env = {**os.environ, "NUMBA_DISABLE_JIT": "1",
           "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    run = subprocess.run([sys.executable, "-c", code, json.dumps(LAST_INTERVAL_PLUCK)], env=env,
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]


def test_kernels_free_every_array_they_allocate():
    """The step loops run without numba's reference counting (``config.JIT_NO_NRT``): the arrays
    ``step_block`` allocates for them, and those the other kernels return, must all be freed.
    numba's allocation counters (``NUMBA_NRT_STATS=1``, in a child) balance over renders that
    take the quiet, held and general paths, a fret added under a hard pluck, and diagnostics."""
    code = (
        "import gc, json, sys, engine\n"
        "from numba.core.runtime import rtsys\n"
        "scenes = json.loads(sys.argv[1])\n"
        "engine.render(scenes[0])  # load the kernels first\n"
        "gc.collect()\n"
        "s0 = rtsys.get_allocation_stats()\n"
        "for sc in scenes:\n"
        "    a = engine.render(sc)\n"
        "    r = engine.render(sc, diagnostics=True)\n"
        "del a, r\n"
        "gc.collect()\n"
        "s1 = rtsys.get_allocation_stats()\n"
        "print(json.dumps([s1.alloc - s0.alloc, s1.free - s0.free, s1.mi_alloc - s0.mi_alloc,\n"
        "                  s1.mi_free - s0.mi_free]))\n")
    scenes = [
        scene([fret(3, 5, time=0.0), pluck(3, time=0.01, force=8.0),
               {"type": "slide", "time": 0.05, "string": 3, "from_fret": 5, "to_fret": 7,
                "duration": 0.03}], 0.1),
        scene([pluck(6, time=0.0, force=8.0), pluck(1, time=0.01, force=2.0)], 0.1),
    ]
    env = {**os.environ, "NUMBA_NRT_STATS": "1",
           "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    run = subprocess.run([sys.executable, "-c", code, json.dumps(scenes)], env=env,
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-2000:]
    alloc, free, mi_alloc, mi_free = json.loads(run.stdout.strip().splitlines()[-1])
    assert alloc > 0 and mi_alloc > 0  # the counters ran
    assert (alloc, mi_alloc) == (free, mi_free)
