"""Instructions per second of audio, counted by valgrind: the engine's cost in a measure that does
not move with the machine.

    python -m tools.instructions [--quality standard] [--seconds 1]
    python -m tools.instructions --waveguide   (the waveguide's C/G strum against the FD model's)

Times move between sessions by more than most changes are worth, and with the vector width of the
machine a session gets (docs/measurements.md, "Speed"); hardware counters
(``tools.counters``) are missing on most of these machines.  This script counts the
instructions of the same renders as ``benchmarks.speed``'s per-string table (the fretted full
model against the linear string at the same factor x, and an open string's 2 N pluck with every
nonlinearity against the linear string), plus its open strum and fretted chord, with
``valgrind --tool=callgrind``, which needs no counters.

How: one child process prepares every scene and renders each once briefly (so that loading the
compiled kernels is not counted), then renders each in full under callgrind with
``--dump-before=getppid``, calling ``os.getppid()`` between renders: each dump holds exactly one
render's instructions (the engine's Python around the kernels included, scene preparation not).

numba compiles for the CPU it runs on, and valgrind 3.19 does not know AVX-512, so the kernels are
compiled for a pinned CPU (``CPU_NAME``, x86-64 with AVX2 and FMA) into a cache of their own, warmed
by a native run of the same child first (under valgrind numba would otherwise compile everything
again, slowly).  The code counted is therefore the same on every x86-64 machine, and it is not the
code this machine's own build runs: the counts measure the code and the scene, not the machine.
Needs ``valgrind`` (Debian: valgrind); the first run also fills the pinned cache.
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

from engine.fd.instrument import prepare
from engine.options import RenderOptions
from engine.scene import Scene
from engine.testing.scenes import (
    LINEAR,
    chord_events,
    fretted_events,
    pluck_events,
    strum_events,
    strum_scene,
)

ROOT = Path(__file__).resolve().parent.parent
CACHE = ROOT / ".numba_cache_pinned"
CPU_NAME = "haswell"
CPU_FEATURES = ("+64bit,+avx,+avx2,+bmi,+bmi2,+cmov,+cx16,+f16c,+fma,+lzcnt,+mmx,+movbe,+popcnt,"
                "+sse,+sse2,+sse3,+sse4.1,+sse4.2,+ssse3,+fxsr,+xsave")

# The child: prepare and warm every configuration, then render each with a dump marker after it.
CHILD = r"""
import json, os, sys
from engine.fd.instrument import prepare
from engine.options import RenderOptions
from engine.scene import Scene
configs = json.loads(sys.argv[1])
def engine_of(c, duration):
    scene = Scene.model_validate({**c["scene"], "duration": duration})
    if scene.model == "waveguide":
        from engine import waveguide
        from engine.models import PRESSED_STRING
        return waveguide.prepare(scene, waveguide.WaveguideOptions(**c["options"]),
                                 statics=PRESSED_STRING)
    return prepare(scene, RenderOptions(**c["options"]))
for c in configs:  # load the kernels for every configuration's types (not counted)
    for _ in engine_of(c, 0.25).blocks():
        pass
engines = [engine_of(c, c["seconds"]) for c in configs]
os.getppid()  # dump: everything before the renders
for eng in engines:
    for _ in eng.blocks():
        pass
    os.getppid()  # dump: this render
"""


def configurations(quality: str, seconds: float) -> list[dict]:
    """``benchmarks.speed``'s per-string renders (x of the fingered string from a native prepare)
    and its strum and chord, as (name, scene without duration, options) for the child."""
    base = {"quality": quality, "output": {"body": "none"}}
    out = []
    for s in range(1, 7):
        full = {**base, "events": fretted_events(s)}
        x = prepare(Scene.model_validate({**full, "duration": 0.1}),
                    RenderOptions(skip_decayed=False)).voices[0].oversample
        hard = {**base, "events": pluck_events(s, 8.0)}
        soft = {**base, "events": pluck_events(s, 2.0)}
        out += [
            {"name": f"{s} fretted", "scene": full, "options": {"skip_decayed": False}},
            {"name": f"{s} linear same x", "scene": hard,
             "options": {**LINEAR, "oversample": x}},
            {"name": f"{s} open full", "scene": soft, "options": {"skip_decayed": False}},
            {"name": f"{s} open linear", "scene": soft, "options": LINEAR},
        ]
    out += [{"name": "six-string strum (open)", "scene": {"quality": quality,
                                                          "events": strum_events()},
             "options": {"skip_decayed": False}},
            {"name": "fretted C chord, strummed", "scene": {"quality": quality,
                                                            "events": chord_events()},
             "options": {"skip_decayed": False}}]
    for c in out:
        c["seconds"] = seconds
    return out


def waveguide_configurations(quality: str) -> list[dict]:
    """``benchmarks.waveguide``'s fretted C/G strum (4 s, no body), on the finite-difference
    model at ``quality`` and on the waveguide, each with its default options (the decay skip on),
    as that benchmark renders them."""
    sc = {k: v for k, v in strum_scene().items() if k != "duration"}
    return [{"name": f"finite difference ({quality})", "scene": {**sc, "quality": quality},
             "options": {}, "seconds": 4.0},
            {"name": "waveguide", "scene": {**sc, "model": "waveguide"}, "options": {},
             "seconds": 4.0}]


def _totals(path: Path) -> int:
    for line in path.read_text().splitlines():
        if line.startswith(("totals:", "summary:")):
            return int(line.split()[1])
    raise ValueError(f"no totals line in {path}")


def callgrind_marked(argv: list[str], env: dict, n: int, cwd: Path | None = None) -> list[int]:
    """Run ``argv`` under callgrind (in ``cwd``) and return the instructions between its first
    n + 1 calls of ``os.getppid()`` (the markers): one count per stretch, in order.  A
    ``python -c`` child puts its working directory ahead of ``PYTHONPATH``: run it in the tree
    whose engine it is meant to import."""
    with tempfile.TemporaryDirectory(prefix="guitar-callgrind-") as tmp:
        out = Path(tmp) / "cg.out"
        run = subprocess.run(["valgrind", "--tool=callgrind", f"--callgrind-out-file={out}",
                              "--dump-before=getppid", *argv], env=env, capture_output=True,
                             text=True, cwd=cwd)
        if run.returncode != 0:
            sys.exit(f"the run under valgrind failed:\n{run.stderr[-3000:]}")
        # dump 1 is everything before the first marker, dump i + 2 the stretch after marker i + 1
        return [_totals(Path(f"{out}.{i + 2}")) for i in range(n)]


def pinned_env() -> dict:
    """The environment of a counted run: this tree, the pinned build's own numba cache and CPU."""
    return {**os.environ, "PYTHONPATH": str(ROOT), "NUMBA_CACHE_DIR": str(CACHE),
            "NUMBA_CPU_NAME": CPU_NAME, "NUMBA_CPU_FEATURES": CPU_FEATURES,
            "PYTHONHASHSEED": "0"}


def count(configs: list[dict]) -> list[int]:
    """Instructions of each configuration's render."""
    env = pinned_env()
    argv = [sys.executable, "-c", CHILD, json.dumps(configs)]
    native = subprocess.run(argv, env=env, capture_output=True, text=True)  # warms the cache
    if native.returncode != 0:
        sys.exit(f"the native warm-up run failed:\n{native.stderr[-3000:]}")
    return callgrind_marked(argv, env, len(configs))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quality", default="standard", choices=["draft", "standard", "high"])
    ap.add_argument("--seconds", type=float, default=1.0)
    ap.add_argument("--waveguide", action="store_true",
                    help="only the fretted C/G strum of benchmarks.waveguide, on both models")
    args = ap.parse_args()
    if shutil.which("valgrind") is None:
        sys.exit("needs valgrind (Debian: apt-get install valgrind)")
    if args.waveguide:
        configs = waveguide_configurations(args.quality)
        fd, wg = count(configs)
        print(f"\nfretted C/G strum of benchmarks.waveguide (4 s, no body), kernels built for "
              f"{CPU_NAME} (callgrind)")
        print(f"  finite difference ({args.quality}): {fd / 4e6:10.1f} million instructions per "
              f"s of audio")
        print(f"  waveguide:{'':{len(args.quality) + 12}s} {wg / 4e6:10.1f} million instructions "
              f"per s of audio")
        print(f"  the waveguide takes {fd / wg:.1f}x fewer instructions")
        return
    configs = configurations(args.quality, args.seconds)
    counts = count(configs)
    per_s = {c["name"]: n / args.seconds / 1e6 for c, n in zip(configs, counts, strict=True)}
    print(f"\ninstructions per second of audio (millions), quality '{args.quality}', "
          f"{args.seconds:g} s renders, body 'none'; kernels built for {CPU_NAME} (callgrind)")
    print("string | linear, same x | fretted full | fretted / linear | open linear | open full | "
          "open full / linear")
    for s in range(1, 7):
        lin, full = per_s[f"{s} linear same x"], per_s[f"{s} fretted"]
        olin, ofull = per_s[f"{s} open linear"], per_s[f"{s} open full"]
        print(f"{s:>6d} | {lin:14.1f} | {full:12.1f} | {full / lin:16.2f} | {olin:11.1f} | "
              f"{ofull:9.1f} | {ofull / olin:18.2f}")
    print("\nscenes (with the preset's acoustic body)")
    print("scene                          | million instructions per s of audio")
    for name in ("six-string strum (open)", "fretted C chord, strummed"):
        print(f"{name:30s} | {per_s[name]:35.1f}")


if __name__ == "__main__":
    main()
