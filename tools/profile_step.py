"""Where a string's time step spends its time, by kernel helper: a sampling profile.

    python -m tools.profile_step [--string 4] [--fret 5] [--no-kc] [--seconds 10]
                                      [--event cpu-clock|cycles|instructions]

Every helper the step loop calls is inlined into one of the loops that ``kernels.step_block`` runs
(``RUNS``: ``_advance``, the general path, to which step_block hands over after allocating its
scratch, and the quiet and the held runs it calls), except the linear pass, a kernel of its own
that all three call (``_pass_kc``, or ``_pass`` without Kirchhoff-Carrier), so a function-level
profiler sees six functions.  This script renders the scene of ``benchmarks.speed``'s component
table (a finger at ``--fret`` and an 8 N pluck on ``--string`` at x1; ``--fret 0``: the open
string) over and over in a child process, twice.  The first child's kernels are compiled as the
engine runs them, and its samples are counted by compiled function: exact, since every sample
lands in one function's code.  The second child's kernels are compiled with line tables
(``NUMBA_DEBUGINFO=1``, in a fresh cache directory, so nothing is reused), samples it with Linux
``perf`` (by default on the software clock: no hardware counters needed, it works in any VM;
``--event instructions`` counts work instead of time where the machine has counters), and maps
every sampled address inside those functions to its source line (binutils' ``addr2line`` on the
compiled object), then to the helper whose ``def`` encloses that line; a run's
own lines, and the lines the tables do not attribute inside a run, get rows of their own.

numba's line tables give an inlined helper's lines the file of the function it was inlined into,
so the second child runs a copy of the engine whose kernels are one module: the package's modules
concatenated, their imports dropped (``_one_file_engine``); the code compiled is the same.

It also prints how many columns the step's small system has (the solves per step by size) and how
many of those systems are arrowheads, from a short render with the kernels run as Python
(``NUMBA_DISABLE_JIT=1``), counting the calls; ``--sizes-only`` prints just that.

Shares are of all samples of each child.  "Outside step_block and its runs" is the Python around
the kernel and every other compiled function; the build with line tables may place code there that
an ordinary build keeps inside ``step_block``, so compare shares within one run.  Caveats:
the line tables change the compiled code slightly; a sample lands on the instruction that waits,
not the one that caused the wait; "no line" is code the compiler did not attribute (spills,
loop control).  Needs ``perf`` (Debian: linux-perf) and ``addr2line`` (binutils).
"""

from __future__ import annotations

import argparse
import ast
import collections
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from engine.options import RenderOptions
from engine.scene import Scene

ROOT = Path(__file__).resolve().parent.parent
KERNELS = ROOT / "engine" / "fd" / "kernels"  # the package: one module per part of the step
# the step loops that step_block runs, and the linear pass they all call (not inlined); each has
# its own rows in the table
RUNS = ("_advance", "_quiet_run", "_held_run", "_pass_kc", "_pass")

# The child: compile, report where step_block's machine code lives, then render until killed.
CHILD = r"""
import json, sys
from tools.profile_step import RUNS, scene_and_options
from engine.fd import kernels
from engine.fd.instrument import prepare
string, fret, kc, ready = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3] == "1", sys.argv[4]
scene, options = scene_and_options(string, fret, kc, 2.0)
eng = prepare(scene, options)
for _ in eng.blocks():
    pass
fn = eng.voices[0]._step_block
ov = next(o for o in kernels.step_block.overloads.values() if o.entry_point is fn)
obj = ov.library.serialize_using_object_code()[2][0]
with open(ready + ".o", "wb") as f:
    f.write(obj)
# step_block and the loops it runs (not inlined): where each one's code lives in this process
where = {}
for name in ("step_block",) + RUNS:
    for o in getattr(kernels, name).overloads.values():
        sym = o.fndesc.llvm_func_name
        try:
            where[sym] = [name, ov.library.get_pointer_to_function(sym)]
        except Exception:  # not linked into step_block's library
            pass
with open(ready, "w") as f:
    json.dump(where, f)
# the longest scene there is: preparing it (the fret calibration) must stay a small share
from engine.scene import MAX_DURATION_S
scene, options = scene_and_options(string, fret, kc, MAX_DURATION_S)
while True:
    for _ in prepare(scene, options).blocks():
        pass
"""


# The sizes: the same scene, 0.25 s, with the kernels as Python functions, counting the solves of
# the step loops: the general path's (``kernels.step``) and the held run's (``kernels.runs``), not
# the one inside ``_ray_blocked`` (``kernels.system``), which solves without the new fret.
SIZES = r"""
import collections, json, sys
from tools.profile_step import scene_and_options
from engine.fd.kernels import runs, step, system
from engine.fd.instrument import prepare
string, fret, kc = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3] == "1"
sizes, arrows = collections.Counter(), collections.Counter()
def counted(A, r, n):
    sizes[n] += 1
    arrows[n] += bool(system._is_arrow(A, n))  # the arrowhead's solver, or pivoting elimination
    return system._solve(A, r, n)
step._solve = runs._solve = counted
eng = prepare(*scene_and_options(string, fret, kc, 0.25))
for _ in eng.blocks():
    pass
print(json.dumps({"steps": eng.voices[0].step, "sizes": sizes, "arrows": arrows}))
"""


def scene_and_options(string: int, fret: int, kc: bool,
                      seconds: float) -> tuple[Scene, RenderOptions]:
    """``benchmarks.speed``'s component scene: a finger at ``fret`` (0: none) and an 8 N pluck at
    0.05 s on ``string``, body 'none', at x1; Kirchhoff-Carrier on or off."""
    events = [{"type": "pluck", "time": 0.05, "string": string, "force": 8.0}]
    if fret:
        events.insert(0, {"type": "fret", "time": 0.0, "string": string, "fret": fret})
    scene = Scene.model_validate({"duration": seconds, "output": {"body": "none"},
                                  "events": events})
    return scene, RenderOptions(oversample=1, skip_decayed=False, kirchhoff_carrier=kc)


def _one_file_engine(tmp: str) -> Path:
    """A copy of the engine in ``tmp`` whose ``kernels`` is one module, ``kernels.py``: the
    package's modules (``data`` first: the others use its constants and classes at import)
    concatenated, each without its docstring and imports, under the imports they make of other
    packages (``...config`` becoming ``..config``).  Returns the folder to put first on PYTHONPATH."""
    src = Path(tmp) / "src"
    shutil.copytree(ROOT / "engine", src / "engine", ignore=shutil.ignore_patterns("__pycache__"))
    # the package's files stay, for the digests of the sources that read them (the calibration
    # store's keys, the kernels' stamps), but not as a package: without its ``__init__.py`` the
    # folder is a namespace package, which ``kernels.py`` beside it takes precedence over
    (src / "engine" / "fd" / "kernels" / "__init__.py").unlink()
    imports = {"from __future__ import annotations": None}
    bodies = []
    modules = sorted(KERNELS.glob("*.py"), key=lambda p: (p.stem != "data", p.stem))
    for path in modules:
        text = path.read_text()
        if path.stem == "__init__":  # only what it imports from outside the package
            for node in ast.parse(text).body:
                if isinstance(node, ast.ImportFrom) and node.level == 3:
                    names = ", ".join(a.name for a in node.names)
                    imports[f"from ..{node.module} import {names}"] = None
            continue
        lines = text.splitlines(keepends=True)
        drop = set()
        for node in ast.parse(text).body:
            if isinstance(node, ast.Import | ast.ImportFrom):
                if isinstance(node, ast.ImportFrom) and node.level == 3:  # from ...config
                    names = ", ".join(a.name for a in node.names)
                    imports[f"from ..{node.module} import {names}"] = None
                elif not (isinstance(node, ast.ImportFrom) and node.level == 1):  # not a sibling
                    imports[ast.get_source_segment(text, node)] = None
            elif not (isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant)):
                continue  # (the module's docstring is dropped too)
            drop.update(range(node.lineno - 1, node.end_lineno))
        bodies.append("".join(x for i, x in enumerate(lines) if i not in drop).strip("\n"))
    (src / "engine" / "fd" / "kernels.py").write_text("\n".join(imports) + "\n\n\n"
                                               + "\n\n\n".join(bodies) + "\n")
    return src


def _helpers(kernels: Path) -> list[tuple[int, str]]:
    """(first line, name) of every top-level def in the one-module kernels, in order."""
    lines = kernels.read_text().splitlines()
    return [(i + 1, m.group(1)) for i, line in enumerate(lines)
            if (m := re.match(r"def (\w+)", line))]


def _helper_of(line: int | None, helpers: list[tuple[int, str]]) -> str:
    if line is None:
        return "(no line)"
    name = "(no line)"
    for first, nm in helpers:
        if first <= line:
            name = nm
    return name


def _symbols(obj: str) -> dict[str, tuple[int, int]]:
    """Offset and size of every sized symbol in the object's text."""
    out = subprocess.run(["nm", "-S", obj], capture_output=True, text=True, check=True).stdout
    return {parts[3]: (int(parts[0], 16), int(parts[1], 16))
            for parts in (row.split() for row in out.splitlines()) if len(parts) == 4}


def _record(tmp: str, string: int, fret: int, kc: bool, seconds: float, event: str,
            line_tables: bool) -> tuple[list[str], list[tuple[int, int, int, str]], str]:
    """Render in a child (compiled into a fresh cache in ``tmp``, with line tables or as the engine
    runs), sample it with perf; returns the sampled addresses, where step_block and its runs live
    ((address in the child, offset in the object, size, function)) and the object's path."""
    ready = os.path.join(tmp, "ready.json")
    env = {**os.environ, "NUMBA_CACHE_DIR": os.path.join(tmp, "nc"),
           "PYTHONPATH": str(ROOT)}
    env.pop("NUMBA_DEBUGINFO", None)
    if line_tables:
        env["NUMBA_DEBUGINFO"] = "1"
        env["PYTHONPATH"] = f"{_one_file_engine(tmp)}{os.pathsep}{ROOT}"
    # (run in tmp: ``python -c`` puts its working folder ahead of PYTHONPATH)
    child = subprocess.Popen([sys.executable, "-c", CHILD, str(string), str(fret),
                              "1" if kc else "0", ready], env=env, cwd=tmp,
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        t0 = time.monotonic()
        while not os.path.exists(ready):
            if child.poll() is not None or time.monotonic() - t0 > 600:
                raise SystemExit("the child did not start rendering (compile failed?)")
            time.sleep(0.5)
        time.sleep(0.5)  # the json is written after the object
        info = json.loads(Path(ready).read_text())
        data = os.path.join(tmp, "perf.data")
        subprocess.run(["perf", "record", "-q", "-e", event, "-F", "20000", "-p",
                        str(child.pid), "-o", data, "--", "sleep", str(seconds)],
                       check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    finally:
        child.kill()
        child.wait()
    ips = subprocess.run(["perf", "script", "-i", data, "-F", "ip"], capture_output=True,
                         text=True, check=True).stdout.split()
    obj = ready + ".o"
    spans = []
    symbols = _symbols(obj)
    for sym, (name, address) in info.items():
        if sym in symbols:  # (compiled for other types elsewhere in the child: not this code)
            spans.append((address, *symbols[sym], name))
    if not any(name == "step_block" for *_, name in spans):
        raise SystemExit("step_block not found in the compiled object")
    return ips, spans, obj


def _by_function(ips: list[str], spans: list[tuple[int, int, int, str]]) -> collections.Counter:
    """Samples per compiled function (step_block and its runs), "outside" for the rest."""
    out: collections.Counter = collections.Counter()
    for ip in ips:
        a = int(ip, 16)
        out[next((name for address, _, size, name in spans if 0 <= a - address < size),
                 "outside")] += 1
    return out


def profile(string: int, fret: int, kc: bool, seconds: float, event: str = "cpu-clock") -> None:
    for tool in ("perf", "addr2line", "nm"):
        if shutil.which(tool) is None:
            raise SystemExit(f"needs `{tool}` on PATH (Debian: linux-perf, binutils)")
    what = f"finger at fret {fret}" if fret else "open string"
    with tempfile.TemporaryDirectory() as tmp:
        ips, spans, _ = _record(tmp, string, fret, kc, seconds, event, line_tables=False)
    funcs = _by_function(ips, spans)
    print(f"string {string} at x1, {what}, 8 N pluck, Kirchhoff-Carrier {'on' if kc else 'off'}, "
          f"compiled as the engine runs: {len(ips)} samples over {seconds:g} s (perf, event "
          f"{event})")
    print("compiled function                           | share of samples")
    for name, n in funcs.most_common():
        label = "outside step_block and its runs" if name == "outside" else name
        print(f"{label:43s} | {100 * n / len(ips):15.1f} %")
    print()
    with tempfile.TemporaryDirectory() as tmp:
        ips, spans, obj = _record(tmp, string, fret, kc, seconds, event, line_tables=True)
        offsets = collections.Counter()
        run_of: dict[int, str] = {}
        for ip in ips:
            a = int(ip, 16)
            for address, start, size, name in spans:
                if 0 <= a - address < size:
                    offsets[start + a - address] += 1
                    run_of[start + a - address] = name
                    break
        addrs = sorted(offsets)
        lines: dict[int, int | None] = {}
        for i in range(0, len(addrs), 2000):
            chunk = addrs[i:i + 2000]
            out = subprocess.run(["addr2line", "-e", obj, *[hex(a) for a in chunk]],
                                 capture_output=True, text=True, check=True).stdout.splitlines()
            for a, loc in zip(chunk, out, strict=True):
                m = re.search(r"kernels\.py:(\d+)", loc)
                lines[a] = int(m.group(1)) if m else None
        helpers = _helpers(Path(tmp) / "src" / "engine" / "fd" / "kernels.py")
    sizes = _sizes(string, fret, kc)
    by_helper: collections.Counter = collections.Counter()
    for a, n in offsets.items():
        helper = _helper_of(lines[a], helpers)
        # a loop's own lines, and the lines it does not attribute, are rows of their own
        run = run_of[a]
        if run != "step_block" and helper in (run, "(no line)"):
            helper = f"{run}'s own lines" if helper == run else f"(no line, {run})"
        by_helper[helper] += n
    total = len(ips)
    inside = sum(offsets.values())
    print(f"the same, compiled with line tables (NUMBA_DEBUGINFO=1): {total} samples over "
          f"{seconds:g} s, by the helper whose source line the sampled instruction has")
    print("where                                       | share of samples")
    print(f"{'outside step_block and its runs':43s} | {100 * (total - inside) / total:15.1f} %")
    for name, n in by_helper.most_common():
        label = "step_block's own lines" if name == "step_block" else name
        print(f"{label:43s} | {100 * n / total:15.1f} %")
    print()
    _print_sizes(sizes)


def _sizes(string: int, fret: int, kc: bool) -> dict:
    return json.loads(subprocess.run(
        [sys.executable, "-c", SIZES, str(string), str(fret), "1" if kc else "0"],
        env={**os.environ, "NUMBA_DISABLE_JIT": "1", "PYTHONPATH": str(ROOT)},
        capture_output=True, text=True, check=True).stdout)


def _print_sizes(sizes: dict) -> None:
    steps = sizes["steps"]
    print(f"solves of the small system per time step, by its size (columns), over the first 0.25 s "
          f"({steps} steps), and the share of them that are arrowheads (``system._solve_arrow``; "
          "the others take pivoting elimination, ``_solve_n``)")
    print("columns | solves per step | arrowheads")
    arrows = {int(k): v for k, v in sizes["arrows"].items()}
    for n, count in sorted((int(k), v) for k, v in sizes["sizes"].items()):
        print(f"{n:7d} | {count / steps:15.3f} | {100 * arrows.get(n, 0) / count:8.1f} %")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--string", type=int, default=4)
    ap.add_argument("--fret", type=int, default=5)
    ap.add_argument("--no-kc", action="store_true", help="switch Kirchhoff-Carrier off")
    ap.add_argument("--seconds", type=float, default=10.0)
    ap.add_argument("--event", default="cpu-clock",
                    help="perf event to sample: cpu-clock (works in any VM), or, where the machine "
                         "has hardware counters, cycles or instructions (a share of instructions "
                         "is a count of work, and does not move with what else the machine does)")
    ap.add_argument("--sizes-only", action="store_true",
                    help="only the solves' table (the kernels run as Python; no perf needed)")
    args = ap.parse_args()
    if args.sizes_only:
        _print_sizes(_sizes(args.string, args.fret, not args.no_kc))
        return
    profile(args.string, args.fret, not args.no_kc, args.seconds, args.event)


if __name__ == "__main__":
    main()
