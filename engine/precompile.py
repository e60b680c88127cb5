"""Compile the numba kernels, or load them from the cache, once per process; and, at install,
everything a first render would otherwise wait for.

    python -m engine.precompile      # every kernel, and the fret calibrations of every preset

``prepare_kernels(models)`` loads (or, the first time on a machine, compiles) just the kernels a
render of those string models calls, by rendering ``KERNEL_SCENES``: the CLI does this before its
progress bar starts, and says so when the kernels are not in the cache yet
(``kernels_cached``).  Compiling is done by one process at a time (a lock file in the cache's
folder): processes started together, like the service's workers on a first start, wait for the
first one and then load what it wrote, instead of each compiling everything.

Kernels are compiled in child processes (``python -m engine.precompile``), one per string model
and all at once (numba compiles on one thread), and every renderer, the first included, loads them
from the cache: the process that compiles a kernel runs code that rounds otherwise than the object
code it writes to the cache where fastmath is on (the finite-difference kernels: ``python -m
tools.render_digest --first-process``), so a render in that process would differ, by rounding, from
the same render in every later one.  Where the children cannot compile (numba's cache off or not
writable), this process compiles.

``WARMUP_SCENES`` are tiny scenes that between them take every numba kernel path a render can
take: fingers (fret, tap, hammer-on, pull-off, slide), rigid frets and the fretboard, the
Kirchhoff-Carrier column, dampers (harmonic, palm mute), tension breakpoints (bend, vibrato),
several pickups, stereo, both built-in bodies and none, the energy terms, oversampled strings
(the decimator), and the waveguide model's sample loop.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import subprocess
import sys
import time
from pathlib import Path

from . import config
from .rendering import render

WARMUP_SCENES: tuple[dict, ...] = (
    {
        "duration": 0.02,
        "diagnostics": True,
        "events": [
            {"type": "fret", "time": 0.0, "string": 5, "fret": 3},
            {"type": "pluck", "time": 0.001, "string": 5},
            {"type": "hammer_on", "time": 0.006, "string": 5, "fret": 5},
            {"type": "pull_off", "time": 0.012, "string": 5, "fret": 5},
            {"type": "slide", "time": 0.0, "string": 4, "from_fret": 2, "to_fret": 4,
             "duration": 0.01},
            {"type": "pluck", "time": 0.001, "string": 4, "style": "pick"},
            {"type": "tap", "time": 0.005, "string": 3, "fret": 7},
        ],
    },
    {
        "duration": 0.02,
        "guitar": {"preset": "nylon-classical"},
        "output": {"channels": 2, "pickups": [{"position": 0.9}, {"position": 0.8, "gain": 0.5}]},
        "events": [
            {"type": "harmonic", "time": 0.0, "string": 1, "fret": 12},
            {"type": "pluck", "time": 0.001, "string": 1},
            {"type": "mute", "time": 0.0, "string": 2},
            {"type": "pluck", "time": 0.001, "string": 2, "style": "slap"},
            {"type": "bend", "time": 0.002, "string": 3, "semitones": 1.0, "duration": 0.005},
            {"type": "pluck", "time": 0.0, "string": 3},
            {"type": "vibrato", "time": 0.002, "string": 6, "duration": 0.01},
            {"type": "pluck", "time": 0.0, "string": 6},
        ],
    },
    {
        "duration": 0.01,
        "guitar": {"preset": "electric"},
        "quality": "draft",
        "output": {"normalize": False},
        "events": [{"type": "strum", "time": 0.0, "spread": 0.005}],
    },
    {  # the waveguide model's kernel (engine.waveguide): one type signature for every scene
        "duration": 0.01,
        "model": "waveguide",
        "events": [{"type": "fret", "time": 0.0, "string": 2, "fret": 3},
                   {"type": "strum", "time": 0.0, "spread": 0.005}],
    },
)


# per string model, a tiny scene whose render calls every kernel a render of that model calls
# from Python with the types a render passes (diagnostics off): the finite-difference step (a
# fretted, oversampled string at ``standard``, and an open one), the decimator and the body filter;
# the waveguide's sample loop and the body filter
KERNEL_SCENES: dict[str, dict] = {
    "fdtd": {"duration": 0.01, "model": "fdtd",
             "events": [{"type": "fret", "time": 0.0, "string": 2, "fret": 3},
                        {"type": "pluck", "time": 0.0, "string": 2},
                        {"type": "pluck", "time": 0.0, "string": 6}]},
    "waveguide": WARMUP_SCENES[-1],
}


def _dispatchers(model: str) -> list:
    """The compiled functions a render of ``model`` calls from Python."""
    from . import models

    return list(models.ENTRY_POINTS[model])


# numba keys a cached kernel by its own source file only: where a helper it calls from another file
# changed (a pull that changes engine/fd/kernels/collisions.py and not step.py), it would load the
# kernel compiled from the old helper, and so would every kernel between them that has a cache of
# its own (the held run, the quiet run, ...).  So next to each entry point's cache lies a digest of
# the sources compiled code is made of (``sources_digest``, in ``_stamp_path``), written once the
# kernel is compiled or loaded; where an entry point's digest differs, or is missing, the cache of
# every compiled function of those sources is flushed (``_kernel_dispatchers``) and they are
# compiled again.
# What the compiled code is made of, under engine/: the flags, the body filter and the decimator,
# the finite-difference kernels and the constants they read, the waveguide's package (its kernel
# reads constants of its other modules).
KERNEL_SOURCES = ("config.py", "output.py", "fd/kernels", "waveguide")


def sources_digest() -> str:
    """SHA-256 of ``KERNEL_SOURCES`` (their paths and bytes)."""
    root = Path(__file__).resolve().parent
    files = []
    for name in KERNEL_SOURCES:
        p = root / name
        files += sorted(p.glob("*.py")) if p.is_dir() else [p]
    h = hashlib.sha256()
    for p in files:
        h.update(p.relative_to(root).as_posix().encode() + b"\0" + p.read_bytes())
    return h.hexdigest()


def _kernel_dispatchers() -> list:
    """Every compiled function of ``KERNEL_SOURCES``' modules (imported with the models)."""
    from numba.core.dispatcher import Dispatcher

    from . import models  # noqa: F401  (imports every kernel module)

    names = ["engine." + source.removesuffix(".py").replace("/", ".") for source in KERNEL_SOURCES]
    found: dict[int, Dispatcher] = {}
    for name, module in list(sys.modules.items()):
        if any(name == n or name.startswith(n + ".") for n in names):
            for obj in vars(module).values():
                if isinstance(obj, Dispatcher):
                    found[id(obj)] = obj
    return list(found.values())


def _stamp_path(d) -> str:
    f = d.py_func
    return os.path.join(d.stats.cache_path, f"{f.__module__}.{f.__qualname__}.sources.sha256")


def _stamped(d, digest: str) -> bool:
    try:
        with open(_stamp_path(d)) as f:
            return f.read().strip() == digest
    except OSError:
        return False


def _stamp(models, digest: str) -> None:
    for m in models:
        for d in _dispatchers(m):
            with contextlib.suppress(OSError), open(_stamp_path(d), "w") as f:
                f.write(digest + "\n")


def kernels_cached(models) -> bool:
    """Whether numba's cache holds, for this machine's CPU and the kernels' current sources (the
    entry points' stamps), the compiled kernels a render of ``models`` calls (so
    ``prepare_kernels`` loads rather than compiles).  Reads numba's cache index (not public API):
    False if it cannot tell."""
    try:
        digest = sources_digest()
        for model in models:
            for d in _dispatchers(model):
                if not _stamped(d, digest):
                    return False
                index = d._cache._cache_file._load_index()
                magic = d.targetctx.codegen().magic_tuple()
                if not any(key[1] == magic for key in index):
                    return False
        return True
    except Exception:  # a numba without these internals: say "not cached", which is safe
        return False


# set in the children that compile (``_compile_in_children``): they compile in their own
# processes, under their parent's lock
CHILD_ENV = "GUITAR_COMPILING_CHILD"


@contextlib.contextmanager
def _compile_lock():
    """One process compiles at a time: the others wait here, then load what it cached.  (The
    child that compiles for its parent runs under the parent's lock.)"""
    if os.environ.get(CHILD_ENV) == "1":
        yield
        return
    folder = os.environ.get("NUMBA_CACHE_DIR") or config.CACHE_DIR
    try:
        import fcntl

        os.makedirs(folder, exist_ok=True)
        f = open(os.path.join(folder, "compile.lock"), "a")  # noqa: SIM115
    except (ImportError, OSError):
        yield
        return
    with f:
        fcntl.flock(f, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(f, fcntl.LOCK_UN)


def _compile_in_children(argvs: list[list[str]]) -> None:
    """Compile the kernels into numba's cache in child processes, ``python -m engine.precompile
    ARGV`` for each of ``argvs``, at once (the module's docstring says why in a child; one child
    per string model, ``compile_jobs()`` at a time, because numba compiles on one thread and the
    models share no compiled function but the output's few, which they compile alike); nothing
    if caching is off (``_compile``, the one caller, starts none from a child).  A child that
    fails leaves the compiling to this process."""
    from numba.core import config as numba_config

    if not config.JIT["cache"] or numba_config.DISABLE_JIT:
        return
    root = str(Path(__file__).resolve().parent.parent)
    path = os.environ.get("PYTHONPATH")
    env = {**os.environ, CHILD_ENV: "1",
           "PYTHONPATH": root if not path else root + os.pathsep + path}
    jobs = compile_jobs()
    for i in range(0, len(argvs), jobs):
        children = [subprocess.Popen([sys.executable, "-m", "engine.precompile", *argv],
                                     env=env, cwd=root, stdout=subprocess.DEVNULL,
                                     stderr=subprocess.DEVNULL) for argv in argvs[i:i + jobs]]
        for child in children:
            child.wait()


def compile_jobs() -> int:
    """How many children compile at once: ``GUITAR_COMPILE_JOBS`` (a positive integer), else
    the cores this process may use.  Each holds one numba compile in memory; 1 compiles the
    models one after the other, where memory is short."""
    value = os.environ.get("GUITAR_COMPILE_JOBS", "").strip()
    if not value:
        return max(1, len(os.sched_getaffinity(0)))
    if not value.isdigit() or int(value) < 1:
        raise ValueError(f"GUITAR_COMPILE_JOBS: a positive integer, not {value!r}")
    return int(value)


def compile_seconds(models) -> int:
    """About how long compiling the kernels of ``models`` takes the first time, s
    (``models.Traits.compile_s``): what the CLI tells a user who waits for it."""
    from .models import TRAITS

    return sum(TRAITS[m].compile_s for m in set(models))


def prepare_kernels(models=("fdtd",)) -> float:
    """Load, or compile once per machine, the kernels a render of ``models`` calls, so that the
    render itself spends no time on them.  Returns the seconds it took."""
    models = sorted(set(models))
    return _load(models, [KERNEL_SCENES[m] for m in models], [])


def _load(models: list[str], scenes: list[dict], flags: list[str]) -> float:
    """Render ``scenes``, which load the kernels of ``models`` from the cache; where they are not
    cached, first compile them, one process at a time (``_compile_lock``), in a child per model
    (``python -m engine.precompile --kernels-only FLAGS --models M``), then stamp them with their
    sources' digest.  Returns the seconds it took."""
    t0 = time.perf_counter()
    if kernels_cached(models):
        for scene in scenes:
            render(scene)
    else:
        with _compile_lock():
            _compile(models, [["--kernels-only", *flags, "--models", m] for m in models])
            for scene in scenes:
                render(scene)
            _stamp(models, sources_digest())
    return time.perf_counter() - t0


def _compile(models, argvs: list[list[str]]) -> None:
    """Under the compile lock: flush what was compiled from other sources, and, unless another
    process compiled the kernels meanwhile, compile them in children (``_compile_in_children``,
    one per argv).  The children flush nothing: the one compiling a model would flush what the
    other has just written."""
    if os.environ.get(CHILD_ENV) == "1":
        return
    digest = sources_digest()
    if not all(_stamped(d, digest) for m in models for d in _dispatchers(m)):
        for d in _kernel_dispatchers():  # none of them is loaded as compiled from other sources
            with contextlib.suppress(Exception):  # (numba's internals: compile as it may)
                d._cache.flush()
    if not kernels_cached(models):
        _compile_in_children(argvs)


def _model_of(scene: dict) -> str:
    from .scene import Scene

    return scene.get("model", Scene.model_fields["model"].default)


def warmup(models=None) -> float:
    """Compile the numba kernels of ``models`` (default: every string model), or load them from
    the cache (``NUMBA_CACHE_DIR``), by rendering their ``WARMUP_SCENES``, so that the first real
    render of a process spends no time compiling; one process at a time when they must be
    compiled.  Returns the seconds it took."""
    models = sorted(set(models or KERNEL_SCENES))
    return _load(models, [s for s in WARMUP_SCENES if _model_of(s) in models], ["--every-path"])


def warm_calibrations(presets=None, models=("fdtd", "waveguide"), qualities=("draft", "standard"),
                      sample_rates=(44100,)) -> float:
    """Calibrate every stopped fret of every string of ``presets`` (default: all) for ``models``
    at ``qualities`` and ``sample_rates``, into the calibration store (``engine.calibration_store``)
    where a later render finds them: preparing a scene that frets each string at every fret does
    it, and, for the waveguide, designing the loop of every stopped and held note (its dispersion
    filter, the finger's damping), which a render does when the note comes.  Returns the seconds
    it took.  ``draft`` is the demo page's default quality (its grids, and so its calibrations,
    are other than ``standard``'s); the waveguide has no quality levels, so its second pass finds
    everything stored."""
    from .mix import prepare
    from .models import TRAITS
    from .presets import PRESETS
    from .scene import Scene

    t0 = time.perf_counter()
    for name in presets or PRESETS:
        preset = PRESETS[name]
        events = [{"type": "fret", "time": 0.01 * q, "string": s, "fret": q}
                  for s in range(1, len(preset.strings) + 1) for q in range(1, preset.frets + 1)]
        for model in models:
            for quality in qualities:
                for rate in sample_rates:
                    mix = prepare(Scene.model_validate(
                        {"duration": 0.5, "sample_rate": rate, "quality": quality,
                         "model": model, "guitar": {"preset": name}, "events": events}))
                    if TRAITS[model].fret_loops:
                        for v in mix.voices:
                            for q in range(1, preset.frets + 1):
                                v.loop(q)
                                v.loop(q, held=True)
    return time.perf_counter() - t0


def main() -> None:
    import argparse

    ap = argparse.ArgumentParser(
        prog="python -m engine.precompile",
        description="Fill the caches a first render would wait for: numba's compiled kernels "
                    "(NUMBA_CACHE_DIR) and the fret calibrations of every preset "
                    "(GUITAR_CACHE_DIR).",
        epilog="Kernels not in the cache compile in a child process per string model, "
               "GUITAR_COMPILE_JOBS at once (default: the cores this process may use).")
    ap.add_argument("--kernels-only", action="store_true", help="no calibrations")
    ap.add_argument("--models", nargs="+", choices=sorted(KERNEL_SCENES),
                    help="only the kernels a render of these string models calls")
    ap.add_argument("--every-path", action="store_true",
                    help="with --models: compile every path a render of those models may take "
                         "(WARMUP_SCENES, as without --models), not only the ones a plain render "
                         "takes (KERNEL_SCENES)")
    args = ap.parse_args()
    if args.models and not args.every_path:
        seconds = prepare_kernels(args.models)
    else:
        seconds = warmup(args.models)
    print(f"compiling kernels (or loading them from the cache) ... {seconds:.1f} s", flush=True)
    if not args.kernels_only:
        print(f"calibrating the frets of every preset ... {warm_calibrations():.1f} s", flush=True)


if __name__ == "__main__":
    main()
