"""engine.fd.kernels.step: the compiled step stays inside its arrays (checked by running it as Python)
and frees every array it allocates."""

import json
import os
import subprocess
import sys
from pathlib import Path

from engine.testing.scenes import fret, pluck, scene

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
           "PYTHONPATH": str(Path(__file__).resolve().parents[3])}
    run = subprocess.run([sys.executable, "-c", code, json.dumps(LAST_INTERVAL_PLUCK)], env=env,
                         capture_output=True, text=True, timeout=300)
    assert run.returncode == 0, run.stderr[-2000:]


def test_kernels_free_every_array_they_allocate():
    """The arrays ``step_block`` allocates for the step loops, and those the other kernels return,
    must all be freed.
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
           "PYTHONPATH": str(Path(__file__).resolve().parents[3])}
    run = subprocess.run([sys.executable, "-c", code, json.dumps(scenes)], env=env,
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-2000:]
    alloc, free, mi_alloc, mi_free = json.loads(run.stdout.strip().splitlines()[-1])
    assert alloc > 0 and mi_alloc > 0  # the counters ran
    assert (alloc, mi_alloc) == (free, mi_free)
