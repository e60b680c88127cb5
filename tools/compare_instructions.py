"""Two or more versions of the engine compared by the instructions their renders take (callgrind):
``tools.compare``'s scenes, counted instead of timed, so that the machine's load does not move them.

    python -m tools.compare_instructions REV [REV ...] [--seconds 0.5] [--scenes fretted,chord]

Each revision is checked out into a temporary worktree with a numba cache of its own, its kernels
built for ``tools.instructions``' pinned CPU (valgrind does not know AVX-512), warmed by a native
run, then rendered under callgrind with a ``os.getppid()`` marker after each render (scene
preparation not counted, the engine's Python around the kernels counted).  The scenes' events are
this tree's (``tools.compare.scenes``), so every revision renders the same scene.  Works on
revisions from before the finite-difference model moved to ``engine/fd/``.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from tools.compare import scenes
from tools.instructions import CPU_FEATURES, CPU_NAME, callgrind_marked

ROOT = Path(__file__).resolve().parent.parent

CHILD = r"""
import json, os, sys
try:
    from engine.fd.instrument import prepare
except ImportError:
    try:
        from engine.instrument import prepare
    except ImportError:
        from engine.guitar import prepare
import engine
from engine import RenderOptions
from engine.scene import Scene
# the engine of the tree being counted, not of wherever this script was started
assert os.path.realpath(engine.__file__).startswith(os.path.realpath(os.getcwd())), engine.__file__
seconds = float(sys.argv[1])
scenes = json.loads(sys.argv[2])
def engine_of(sc, duration):  # the events before ``duration`` (the warm-up's is shorter)
    events = [e for e in sc["events"] if e["time"] < duration]
    return prepare(Scene.model_validate({**sc, "events": events, "duration": duration}),
                   RenderOptions(skip_decayed=False))
for sc in scenes.values():  # load the kernels for every scene's types (not counted)
    for _ in engine_of(sc, 0.25).blocks():
        pass
engines = [engine_of(sc, seconds) for sc in scenes.values()]
os.getppid()
for eng in engines:
    for _ in eng.blocks():
        pass
    os.getppid()
"""

SHORT = {"fretted": lambda n: n.startswith("string"), "E2": lambda n: n.startswith("string 6"),
         "chord": lambda n: "chord" in n, "strum": lambda n: "strum" in n,
         "slide": lambda n: "slide" in n}


def count_tree(tree: Path, chosen: dict, seconds: float) -> list[int]:
    import os
    env = {**os.environ, "PYTHONPATH": str(tree), "NUMBA_CACHE_DIR": str(tree / ".numba_pinned"),
           "NUMBA_CPU_NAME": CPU_NAME, "NUMBA_CPU_FEATURES": CPU_FEATURES, "PYTHONHASHSEED": "0"}
    argv = [sys.executable, "-c", CHILD, str(seconds), json.dumps(chosen)]
    native = subprocess.run(argv, env=env, cwd=tree, capture_output=True, text=True)
    if native.returncode != 0:
        sys.exit(f"the native warm-up run in {tree} failed:\n{native.stderr[-3000:]}")
    return callgrind_marked(argv, env, len(chosen), tree)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("revs", nargs="+", help="git revisions; WORK means this working tree as is")
    ap.add_argument("--seconds", type=float, default=0.5)
    ap.add_argument("--keep", action="store_true", help="keep each revision's worktree (and its "
                    "compiled kernels) in /tmp/guitar-cmpins-REV for the next run")
    ap.add_argument("--scenes", default="", help="comma-separated: fretted, E2, chord, strum, "
                    "slide (default: all of tools.compare's)")
    args = ap.parse_args()
    if shutil.which("valgrind") is None:
        sys.exit("needs valgrind (Debian: apt-get install valgrind)")
    all_scenes = scenes()
    keys = [k for k in args.scenes.split(",") if k]
    chosen = {n: s for n, s in all_scenes.items()
              if not keys or any(SHORT[k](n) for k in keys)}
    counts: dict[str, list[int]] = {}
    with tempfile.TemporaryDirectory(prefix="guitar-cmpins-") as tmp:
        for r in args.revs:
            if r == "WORK":
                counts[r] = count_tree(ROOT, chosen, args.seconds)
                continue
            sha = subprocess.run(["git", "rev-parse", "--short", r], cwd=ROOT, check=True,
                                 capture_output=True, text=True).stdout.strip()
            tree = (Path(tempfile.gettempdir()) if args.keep else Path(tmp)) / f"guitar-cmpins-{sha}"
            if not tree.exists():
                subprocess.run(["git", "worktree", "add", "--detach", "-q", str(tree), r],
                               cwd=ROOT, check=True)
            try:
                counts[r] = count_tree(tree, chosen, args.seconds)
            finally:
                if not args.keep:
                    subprocess.run(["git", "worktree", "remove", "--force", str(tree)], cwd=ROOT,
                                   check=False)
            print(f"{r} counted", file=sys.stderr, flush=True)
    first = args.revs[0]
    print(f"\nmillion instructions per second of audio (callgrind, kernels built for {CPU_NAME}), "
          f"{args.seconds:g} s renders, quality 'standard'; ratio against {first}")
    print(f"{'scene':30s} | {first[:9]:>9s} | "
          + " | ".join(f"{r[:9]:>9s}  ratio" for r in args.revs[1:]))
    for i, name in enumerate(chosen):
        base = counts[first][i]
        cells = [f"{base / args.seconds / 1e6:9.1f}"]
        cells += [f"{counts[r][i] / args.seconds / 1e6:9.1f} {counts[r][i] / base:6.3f}"
                  for r in args.revs[1:]]
        print(f"{name:30s} | " + " | ".join(cells))


if __name__ == "__main__":
    main()
