"""Two versions of the engine timed against each other, interleaved, on this machine.

    python -m tools.compare REV_A REV_B [--rounds 3] [--repeat 5] [--seconds 1] [--each-round]

A revision that names a directory is that checked-out tree as it is, with its own numba cache
(``NUMBA_CACHE_DIR`` = its ``.numba_cache``), so a warm tree compiles nothing.

Timings on this shared machine drift by more than most kernel changes are worth, between sessions
and within one (``benchmarks.speed``'s notes), so one run of ``benchmarks.speed`` before a change
and one after cannot tell a 10 % gain from noise.  This script checks out both git revisions into
temporary worktrees, each with a numba cache of its own, and times the same scenes with each in
turn, ``--rounds`` times, the order of the two swapped every round: drift then moves both
columns alike.  Each cell is the best CPU time of ``--repeat`` renders (scene preparation
excluded, as in ``benchmarks.speed``), and the table gives the best of all rounds per version,
and B's time as a share of A's.  ``--each-round`` also prints every round's cells: this machine
runs for seconds at a time about 1.5 times slower than at other times, whatever it runs, and a
version whose rounds all fell in such stretches shows it there.

Scenes: each string fretted at fret 5 with an 8 N pluck (the fretted full model of
``benchmarks.speed``'s first table, at the oversampling factor the ``standard`` level gives it),
the fretted C chord and the open strum of its second table, and a slide from fret 5 to 7 on
string 3, whose moving finger keeps the steps of the slide out of the held run (they take the
general path).  A worktree's first round also compiles its kernels (not timed).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path

from engine.testing.scenes import chord_events, fretted_events, strum_events

ROOT = Path(__file__).resolve().parent.parent

# The child: time every scene with the engine of the worktree it runs in, print JSON.
CHILD = r"""
import json, sys
try:
    from tools.timing import best_time
except ImportError:  # a revision from before tools.timing
    from benchmarks.speed import best_time
from engine import RenderOptions
seconds, repeat = float(sys.argv[1]), int(sys.argv[2])
scenes = json.loads(sys.argv[3])
out = {}
for name, sc in scenes.items():
    sc = {**sc, "duration": seconds}
    out[name] = best_time(sc, RenderOptions(skip_decayed=False), repeat).seconds / seconds
print(json.dumps(out))
"""


def scenes() -> dict[str, dict]:
    """The scenes without their duration: the strings with no body, as in ``benchmarks.speed``'s
    per-string table, the chord and the strum with the preset's, as in its scenes table."""
    out = {f"string {s}, fret 5, 8 N": {"events": fretted_events(s), "output": {"body": "none"}}
           for s in range(1, 7)}
    out["fretted C chord, strummed"] = {"events": chord_events()}
    out["six-string strum (open)"] = {"events": strum_events()}
    out["slide 5 -> 7, string 3"] = {"events": [
        {"type": "fret", "time": 0.0, "string": 3, "fret": 5},
        {"type": "pluck", "time": 0.05, "string": 3, "force": 2.0},
        {"type": "slide", "time": 0.4, "string": 3, "from_fret": 5, "to_fret": 7,
         "duration": 0.15}], "output": {"body": "none"}}
    return out


def run(tree: Path, seconds: float, repeat: int) -> dict[str, float]:
    env = {**os.environ, "PYTHONPATH": str(tree), "NUMBA_CACHE_DIR": str(tree / ".numba_cache")}
    res = subprocess.run([sys.executable, "-c", CHILD, str(seconds), str(repeat),
                          json.dumps(scenes())], cwd=tree, env=env, capture_output=True, text=True)
    if res.returncode != 0:
        sys.exit(f"timing the engine in {tree} failed:\n{res.stderr}")
    return json.loads(res.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("rev_a")
    ap.add_argument("rev_b")
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--seconds", type=float, default=1.0)
    ap.add_argument("--each-round", action="store_true",
                    help="also print every round's time of each scene for both versions")
    args = ap.parse_args()
    revs = {}
    for r in (args.rev_a, args.rev_b):
        if Path(r).is_dir():  # a checked-out tree as it is (its own numba cache kept warm)
            revs[r] = r
            continue
        revs[r] = subprocess.run(["git", "rev-parse", "--short", r], cwd=ROOT, check=True,
                                 capture_output=True, text=True).stdout.strip()
    with tempfile.TemporaryDirectory(prefix="guitar-compare-") as tmp:
        trees = {}
        try:
            for r, short in revs.items():
                if Path(r).is_dir():
                    trees[r] = Path(r).resolve()
                    run(trees[r], args.seconds, 1)
                    continue
                tree = Path(tmp) / short
                subprocess.run(["git", "worktree", "add", "--detach", "-q", str(tree), r],
                               cwd=ROOT, check=True)
                trees[r] = tree
                run(tree, args.seconds, 1)  # compile (or load) the kernels
            rounds: dict[str, dict[str, list[float]]] = {r: {} for r in revs}
            for i in range(args.rounds):
                order = list(trees.items())
                for r, tree in order if i % 2 == 0 else order[::-1]:
                    for name, t in run(tree, args.seconds, args.repeat).items():
                        rounds[r].setdefault(name, []).append(t)
                print(f"round {i + 1} of {args.rounds} done", file=sys.stderr, flush=True)
        finally:
            for r, tree in trees.items():
                if Path(r).is_dir():
                    continue
                subprocess.run(["git", "worktree", "remove", "--force", str(tree)], cwd=ROOT,
                               check=False)
    a, b = args.rev_a, args.rev_b
    best = {r: {name: min(ts) for name, ts in rounds[r].items()} for r in revs}
    if args.each_round:
        print("\nms of compute per second of audio in each round (A first in odd rounds)")
        print(f"A = {revs[a]}, B = {revs[b]}")
        for name in scenes():
            print(f"{name:30s} | A " + " ".join(f"{t * 1e3:7.2f}" for t in rounds[a][name])
                  + " | B " + " ".join(f"{t * 1e3:7.2f}" for t in rounds[b][name]))
    print(f"\nms of compute per second of audio, best of {args.rounds} interleaved rounds of "
          f"{args.repeat} renders ({args.seconds:g} s each), quality 'standard'")
    print(f"A = {revs[a]}, B = {revs[b]}")
    print(f"{'scene':30s} | {'A':>8s} | {'B':>8s} | B / A")
    for name in scenes():
        ta, tb = best[a][name] * 1e3, best[b][name] * 1e3
        print(f"{name:30s} | {ta:8.2f} | {tb:8.2f} | {tb / ta:5.3f}")


if __name__ == "__main__":
    main()
