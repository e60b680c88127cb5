"""tools/compile_time.py listens to numba's compile events in the process it starts, so that
process must compile the kernels itself, not hand them to a child of its own."""

import json
import subprocess

from engine.precompile import CHILD_ENV
from tools import compile_time


def test_the_measured_process_compiles_in_itself(monkeypatch):
    seen = {}

    def run(argv, **kw):
        seen.update(kw["env"])
        return subprocess.CompletedProcess(argv, 0, json.dumps({"total": 1.0, "rows": {}}), "")

    monkeypatch.setattr(compile_time.subprocess, "run", run)
    assert compile_time.measure("waveguide", None) == {"total": 1.0, "rows": {}}
    assert seen[CHILD_ENV] == "1" and seen["NUMBA_CACHE_DIR"]
