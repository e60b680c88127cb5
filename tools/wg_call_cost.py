"""Instructions of one call of the waveguide kernel that runs no step: what a call costs before its
first sample (unboxing its arguments, the prologue), counted by valgrind.

    python -m tools.wg_call_cost [--calls 20000]

A string is prepared and rendered briefly (``engine.waveguide``), the compiled kernel and the
arguments of its first call are kept (``voice.entry_point``), and the kernel is called again with
an empty output ``--calls`` times between two ``os.getppid()`` markers under callgrind (the
pinned CPU and cache of ``tools.instructions``; Python's loop around the calls is counted too).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys

from tools.instructions import CACHE, CPU_FEATURES, CPU_NAME, ROOT, callgrind_marked

CHILD = r"""
import os, sys
import numpy as np
import engine.waveguide.voice as wv
from engine import waveguide
from engine.models import PRESSED_STRING
from engine.scene import Scene
calls = int(sys.argv[1])
kept = []
entry = wv.entry_point
def keep(dispatcher, args):
    fn = entry(dispatcher, args)
    def run(*a):
        if not kept:
            kept.append((fn, list(a)))
        return fn(*a)
    return run
wv.entry_point = keep
sc = Scene.model_validate({"duration": 0.1, "model": "waveguide", "events": [
    {"type": "fret", "time": 0, "string": 5, "fret": 3},
    {"type": "pluck", "time": 0.01, "string": 5}]})
for _ in waveguide.prepare(sc, waveguide.WaveguideOptions(), statics=PRESSED_STRING).blocks():
    pass
fn, a = kept[0]
if len(a) > 4:  # run_block(rails, ist, fst, ds, step0, nsteps, out, ...): no step
    a[5], a[6] = 0, np.zeros(0)
else:  # run_block(wave, events, step0, out)
    a[3] = np.zeros(0)
for _ in range(100):
    fn(*a)
os.getppid()
for _ in range(calls):
    fn(*a)
os.getppid()
"""


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--calls", type=int, default=20000)
    args = ap.parse_args()
    env = {**os.environ, "PYTHONPATH": str(ROOT), "NUMBA_CACHE_DIR": str(CACHE),
           "NUMBA_CPU_NAME": CPU_NAME, "NUMBA_CPU_FEATURES": CPU_FEATURES,
           "PYTHONHASHSEED": "0"}
    argv = [sys.executable, "-c", CHILD, str(args.calls)]
    native = subprocess.run(argv, env=env, capture_output=True, text=True)  # warms the cache
    if native.returncode != 0:
        sys.exit(f"the native run failed:\n{native.stderr[-3000:]}")
    (calls,) = callgrind_marked(argv, env, 1)
    print(f"waveguide kernel, a call that runs no step: {calls / args.calls:.0f} instructions "
          f"(kernels built for {CPU_NAME}, callgrind; {args.calls} calls)")


if __name__ == "__main__":
    main()
