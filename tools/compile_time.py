"""Where a first render's compile time goes: each kernel numba compiles for a string model, from
an empty cache, and how much of it is LLVM's.

    python -m tools.compile_time [--models fdtd waveguide] [--opt 0..3]

For each model, a fresh process with an empty ``NUMBA_CACHE_DIR`` loads the kernels a render of
that model calls (``engine.prepare_kernels``, as the CLI does before its first render) while
listening to numba's compile events (``numba.core.event``): per function compiled from Python
(helpers compiled for its calls are counted in it), its wall time and the part of it numba spent
holding its LLVM lock (optimising and emitting machine code; the rest is numba's own typing and
lowering, in Python).  The fret calibrations come from the usual store, so only compiling is timed.
``--opt`` compiles at another LLVM optimisation level (``NUMBA_OPT``; numba's default is 3).  It
says what a cold start is made of, and so what would shorten it: fewer or smaller kernels, another
optimisation level, or kernels compiled ahead of time.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from engine.precompile import CHILD_ENV  # noqa: E402

CHILD = r"""
import json, sys, time
from numba.core import event

rows, depth, llvm_depth = {}, [0], [0]
current = [None]


class Compiles(event.Listener):
    def on_start(self, ev):
        if depth[0] == 0:
            d = ev.data.get("dispatcher")
            name = getattr(getattr(d, "py_func", None), "__qualname__", "?")
            module = getattr(getattr(d, "py_func", None), "__module__", "?")
            current[0] = [f"{module}.{name}", time.perf_counter(), 0.0]
        depth[0] += 1

    def on_end(self, ev):
        depth[0] -= 1
        if depth[0] == 0 and current[0] is not None:
            name, t0, llvm = current[0]
            wall, old = time.perf_counter() - t0, rows.get(name, (0.0, 0.0, 0))
            rows[name] = (old[0] + wall, old[1] + llvm, old[2] + 1)
            current[0] = None


class Llvm(event.Listener):
    def on_start(self, ev):
        llvm_depth[0] += 1
        if llvm_depth[0] == 1:
            self.t0 = time.perf_counter()

    def on_end(self, ev):
        llvm_depth[0] -= 1
        if llvm_depth[0] == 0 and current[0] is not None:
            current[0][2] += time.perf_counter() - self.t0


event.register("numba:compile", Compiles())
event.register("numba:llvm_lock", Llvm())
import engine

t0 = time.perf_counter()
engine.prepare_kernels([sys.argv[1]])
total = time.perf_counter() - t0
print(json.dumps({"total": total, "rows": rows}))
"""


def measure(model: str, opt: int | None) -> dict:
    with tempfile.TemporaryDirectory(prefix="guitar-compile-") as cache:
        # as the child engine.precompile starts to compile: here, in the process that listens
        # (without it, prepare_kernels would compile in a child of its own, out of earshot)
        env = {**os.environ, "PYTHONPATH": str(ROOT), "NUMBA_CACHE_DIR": cache, CHILD_ENV: "1"}
        if opt is not None:
            env["NUMBA_OPT"] = str(opt)
        res = subprocess.run([sys.executable, "-c", CHILD, model], cwd=ROOT, env=env,
                             capture_output=True, text=True)
    if res.returncode != 0:
        sys.exit(f"compiling {model} failed:\n{res.stderr[-2000:]}")
    return json.loads(res.stdout.strip().splitlines()[-1])


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--models", nargs="+", choices=("fdtd", "waveguide"),
                    default=["fdtd", "waveguide"])
    ap.add_argument("--opt", type=int, choices=range(4), help="LLVM's optimisation level "
                    "(NUMBA_OPT; default: numba's, 3)")
    args = ap.parse_args(argv)
    print(f"LLVM optimisation level {3 if args.opt is None else args.opt}; load average at the "
          f"start: {' / '.join(f'{x:.2f}' for x in os.getloadavg())}\n")
    print("| model | function compiled from Python | times | wall s | of which LLVM s |")
    print("| --- | --- | ---: | ---: | ---: |")
    for model in args.models:
        m = measure(model, args.opt)
        rows = sorted(m["rows"].items(), key=lambda kv: -kv[1][0])
        for name, (wall, llvm, n) in rows:
            if wall >= 0.05:
                print(f"| {model} | `{name}` | {n} | {wall:.1f} | {llvm:.1f} |", flush=True)
        print(f"| {model} | **prepare_kernels, in all** | | {m['total']:.1f} | "
              f"{sum(r[1] for r in m['rows'].values()):.1f} |", flush=True)


if __name__ == "__main__":
    main()
