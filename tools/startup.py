"""What a warm CLI render spends before and after it renders: its start-up and its exit, phase by
phase, and what two of the start-up's choices save.

    python -m tools.startup [--models waveguide fdtd] [--rounds 7] [--all-cores]

Each round runs, for each model and each variant, one fresh process that renders a 50 ms note
through the CLI (``cli.main.main(["render", ...])``), after importing, one by one, what the CLI
would import, and reads its own CPU time (``time.process_time``: all its threads) after each phase:

* ``python``: the interpreter's start, up to the first line of the child;
* ``numpy``, ``numba``: importing them;
* ``engine``: importing the CLI and the engine (the scene's schema, the models, the kernels'
  modules);
* ``registries``: numba's lowering registries, which it imports when a process first compiles or
  loads a kernel (``numba.np.arraymath`` among them, with its BLAS probe);
* ``render``: the CLI's render: reading and validating the scene, loading the model's compiled
  kernels from numba's cache, rendering, writing the WAV;
* ``exit``: the rest of the process's CPU time (``wait4``), from there to its end: the
  interpreter's finalisation, whose garbage collections walk every object the collector sees.

The variants:

* ``as shipped``: the engine and the CLI as they run (``engine.config._SkipBlasProbe`` refuses
  ``scipy.linalg`` to numba's probe; the CLI freezes what it holds once the kernels are loaded,
  ``gc.freeze``);
* ``BLAS probe``: ``GUITAR_NUMBA_BLAS_PROBE=1``, which leaves the probe to numba;
* ``unfrozen``: ``gc.unfreeze()`` once the CLI has rendered, so that the exit walks it all.

The processes are pinned to one core, as ``benchmarks.songs`` pins its renders, unless
``--all-cores`` (then OpenBLAS's threads, which ``scipy.linalg`` starts, run on the other cores
too).  The table gives each phase's median over the rounds, and the whole process's least and
median CPU time.  The kernels must be in the cache (``make install``): a compile would swamp the
table, and the tool stops if one would happen.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

CHILD = r"""
import gc, json, os, sys, time
T = time.process_time
marks = {"python": T()}
import numpy
marks["numpy"] = T()
import numba
marks["numba"] = T()
import cli.main, engine, engine.rendering, engine.models
marks["engine"] = T()
from numba.core.registry import cpu_target
cpu_target.target_context.refresh()
marks["registries"] = T()
model, scene, out, unfreeze = sys.argv[1:5]
if not engine.kernels_cached([model]):
    sys.exit(f"the {model} kernels are not in numba's cache: run `make install` first")
code = cli.main.main(["render", scene, "-o", out, "-q", "--model", model])
marks["render"] = T()
marks["linalg"] = "scipy.linalg" in sys.modules
if unfreeze == "1":
    gc.unfreeze()
print(json.dumps(marks), flush=True)
sys.exit(code)
"""

PHASES = ("python", "numpy", "numba", "engine", "registries", "render")
# name: (environment, unfreeze before the exit)
VARIANTS = {"as shipped": ({}, False), "BLAS probe": ({"GUITAR_NUMBA_BLAS_PROBE": "1"}, False),
            "unfrozen": ({}, True)}
NOTE = {"duration": 0.05, "events": [{"type": "pluck", "time": 0.0, "string": 1}]}


def child(model: str, variant: str, core: int | None, tmp: Path) -> tuple[dict, float]:
    """One process: its phases' CPU seconds, and its whole CPU time (``wait4``)."""
    extra, unfreeze = VARIANTS[variant]
    env = {k: v for k, v in os.environ.items() if k != "GUITAR_NUMBA_BLAS_PROBE"}
    env.update(PYTHONPATH=str(ROOT), **extra)
    argv = [sys.executable, "-c", CHILD, model, str(tmp / "note.json"), str(tmp / "note.wav"),
            "1" if unfreeze else "0"]
    pre = (lambda: os.sched_setaffinity(0, {core})) if core is not None else None
    with tempfile.TemporaryFile() as out, tempfile.TemporaryFile() as err:
        proc = subprocess.Popen(argv, cwd=ROOT, env=env, stdout=out, stderr=err, preexec_fn=pre)
        _, status, usage = os.wait4(proc.pid, 0)
        if os.waitstatus_to_exitcode(status) != 0:
            err.seek(0)
            sys.exit(err.read().decode(errors="replace").strip().splitlines()[-1])
        out.seek(0)
        marks = json.loads(out.read().decode().strip().splitlines()[-1])
    phases, last = {}, 0.0
    for name in PHASES:
        phases[name] = marks[name] - last
        last = marks[name]
    total = usage.ru_utime + usage.ru_stime
    phases["exit"] = total - last
    phases["linalg"] = marks["linalg"]
    return phases, total


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--models", nargs="+", choices=("fdtd", "waveguide"),
                    default=["waveguide", "fdtd"])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--all-cores", action="store_true", help="do not pin the processes")
    args = ap.parse_args(argv)
    core = None if args.all_cores else min(os.sched_getaffinity(0))
    runs: dict[tuple[str, str], list[tuple[dict, float]]] = {}
    with tempfile.TemporaryDirectory(prefix="guitar-startup-") as d:
        tmp = Path(d)
        (tmp / "note.json").write_text(json.dumps(NOTE))
        for _ in range(args.rounds):  # in rounds: a host whose speed drifts slows each alike
            for model in args.models:
                for variant in VARIANTS:
                    runs.setdefault((model, variant), []).append(child(model, variant, core, tmp))
    where = f"pinned to core {core}" if core is not None else "on all cores"
    print(f"CPU seconds of a warm CLI render of a 50 ms note, phase by phase: median of "
          f"{args.rounds} rounds, {where}.\n")
    columns = (*PHASES, "exit")
    print("| model | variant | " + " | ".join(columns) + " | total: least | median "
          "| scipy.linalg imported |")
    print("| --- | --- |" + " ---: |" * (len(columns) + 2) + " --- |")
    for (model, variant), rs in runs.items():
        cells = " | ".join(f"{statistics.median(p[name] for p, _ in rs):.3f}" for name in columns)
        totals = [t for _, t in rs]
        imported = {p["linalg"] for p, _ in rs}
        linalg = "sometimes" if len(imported) > 1 else "yes" if imported.pop() else "no"
        print(f"| {model} | {variant} | {cells} | {min(totals):.3f} | "
              f"{statistics.median(totals):.3f} | {linalg} |")
    print()
    for model in args.models:
        shipped = statistics.median(t for _, t in runs[(model, "as shipped")])
        for variant, what in (("BLAS probe", "skipping numba's BLAS probe"),
                              ("unfrozen", "freezing the heap before the exit")):
            other = statistics.median(t for _, t in runs[(model, variant)])
            print(f"{model}: {what} saves {other - shipped:.3f} s of CPU per process (median; "
                  f"{100 * (other - shipped) / other:.0f} % of it)")


if __name__ == "__main__":
    main()
