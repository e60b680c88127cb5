"""Held steps against the general path on the stability soak's random scenes.

    python -m tools.held_soak [--seed 0] [--cases 300 | --cases 42,102,181]

Each short case of ``benchmarks.soak`` (the same generator and numbering) is rendered with held
steps (``kernels._held_run``) and without (``RenderOptions(held_steps=False)``); the table gives
the largest difference as a share of the peak, and the energy balance (sec. 6.1) of the render
with held steps and diagnostics.  The two paths do the same arithmetic, in loops compiled
without fastmath that call one compiled linear pass (``engine.config.JIT_STEP``), so every
difference should be 0.  Loops each compiled with fastmath would let LLVM contract and
re-associate each its own way, and on a string that rattles against frets and board a last-bit
difference can decide a contact one step earlier, from where the renders part.
``GUITAR_NUMBA_FASTMATH=0`` (with a numba cache of its own, so that kernels compiled with the flags
are not loaded instead) compiles the pass without fastmath too:

    GUITAR_NUMBA_FASTMATH=0 NUMBA_CACHE_DIR=/tmp/nofm python -m tools.held_soak --cases 42,102
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from pydantic import ValidationError

from engine.config import FASTMATH
from engine.fd.instrument import prepare
from engine.options import RenderOptions
from engine.scene import Scene
from engine.testing.measure import held_steps
from engine.testing.random_scenes import soak_case as make_case


def compare(seed: int, i: int) -> tuple[float, int, int, float] | None:
    """(largest |difference| / peak, held steps, all steps, relative energy-balance deviation with
    held steps) of case i; None if it is not a valid short case."""
    kind, sc = make_case(seed, i)
    if kind != "short":
        return None
    try:
        scene = Scene.model_validate(sc)
    except ValidationError:
        return None
    outs, held, steps = [], 0, 0
    for on in (True, False):
        eng = prepare(scene, RenderOptions(held_steps=on))
        outs.append(np.concatenate(list(eng.blocks())))
        if on:
            held, steps = held_steps(eng)
    eng = prepare(Scene.model_validate({**sc, "diagnostics": True}), RenderOptions())
    for _ in eng.blocks():
        pass
    peak = float(np.max(np.abs(outs[1]))) or 1.0
    return float(np.max(np.abs(outs[0] - outs[1]))) / peak, held, steps, eng.energy_error()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--cases", default="300", help="a count (cases 0..n-1) or a list: 42,102")
    args = ap.parse_args()
    cases = ([int(c) for c in args.cases.split(",")] if "," in args.cases
             else range(int(args.cases)))
    t = time.perf_counter()
    rows = [(r, i) for i in cases if (r := compare(args.seed, i)) is not None]
    held = [(r, i) for r, i in rows if r[1] > 0]
    print(f"seed {args.seed}: {len(rows)} short valid cases, {len(held)} with held steps, "
          f"{time.perf_counter() - t:.0f} s; linear pass compiled "
          f"{'with' if FASTMATH else 'without'} fastmath, step loops without")
    diffs = np.array([r[0] for r, _ in held])
    if len(diffs):
        print(f"largest |difference| / peak over the cases with held steps: median "
              f"{np.median(diffs):.2e}, 90th percentile {np.quantile(diffs, 0.9):.2e}; "
              f"identical in {int(np.sum(diffs == 0.0))} of {len(diffs)}, below 1e-9 in "
              f"{int(np.sum(diffs < 1e-9))}")
        print("energy balance with held steps (diagnostics, held steps on), worst: "
              f"{max(r[3] for r, _ in held):.2e}")
    print("case | |difference| / peak | held steps | steps | energy balance")
    for (d, h, n, e), i in sorted(held, key=lambda x: -x[0][0])[:10]:
        print(f"{i:4d} | {d:19.2e} | {h:10d} | {n:5d} | {e:14.2e}")


if __name__ == "__main__":
    main()
