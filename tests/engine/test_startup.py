"""What a rendering process imports: numba's BLAS probe is skipped (``config._SkipBlasProbe``), so
a render of either model never imports ``scipy.linalg`` (``python -m tools.startup`` prints what
that saves a process), while every other use of it, numba's own linear algebra included, works as
before."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from engine import precompile

ROOT = Path(__file__).resolve().parents[2]

# renders both models, reports what was imported, then uses scipy.linalg and numba's np.dot
CHILD = r"""
import json, sys
import numpy as np
import engine
for model in ("fdtd", "waveguide"):
    engine.render({"duration": 0.05, "model": model, "quality": "standard",
                   "events": [{"type": "fret", "time": 0.0, "string": 1, "fret": 5},
                              {"type": "pluck", "time": 0.0, "string": 1}]})
import numba.np.arraymath
report = {"linalg": "scipy.linalg" in sys.modules,
          "have_blas": bool(numba.np.arraymath._HAVE_BLAS)}
import scipy.linalg
from numba import njit
a = np.arange(6.0).reshape(2, 3)
b = np.arange(12.0).reshape(3, 4)
report["lu_ok"] = bool(np.allclose(scipy.linalg.lu(b @ b.T)[0].shape, (3, 3)))
report["dot_ok"] = bool(np.array_equal(njit(lambda x, y: np.dot(x, y))(a, b), a @ b))
print(json.dumps(report))
"""


def _child(env_extra: dict) -> dict:
    env = {**os.environ, "PYTHONPATH": str(ROOT), **env_extra}
    out = subprocess.run([sys.executable, "-c", CHILD], env=env, cwd=ROOT, capture_output=True,
                         text=True, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


@pytest.fixture(scope="module")
def kernels():
    precompile.prepare_kernels(["fdtd", "waveguide"])  # the children load, not compile


def test_a_render_does_not_import_scipy_linalg(kernels):
    report = _child({})
    assert report == {"linalg": False, "have_blas": False, "lu_ok": True, "dot_ok": True}


def test_the_probe_runs_when_asked(kernels):
    """The same child with the probe left to numba imports scipy.linalg during the render: what
    the first test checks is the finder's doing, not an accident of the imports."""
    report = _child({"GUITAR_NUMBA_BLAS_PROBE": "1"})
    assert report == {"linalg": True, "have_blas": True, "lu_ok": True, "dot_ok": True}
