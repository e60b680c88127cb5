"""The layers of docs/architecture.md, as the imports say them: every engine module imports only
modules below it, the schema loads no numerics, and the service reaches the engine only through
its public package (and the schema's limits)."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

ENGINE = ROOT / "engine"
# low to high, as engine/__init__.py lists them; a module may import only those before it.  A
# module of ``fd`` is a layer of its own (``fd.kernels`` one for the package); ``waveguide``,
# ``score`` and ``testing`` are one layer each
ORDER = ["config", "presets", "effect_specs", "scene", "live_events", "analysis", "losses",
         "performance", "options", "fd.grid", "cost", "score", "calibration_store", "output",
         "instrument", "statics", "fd.kernels", "fd.string", "fd.controls", "fd.intonation",
         "fd.statics", "fd.voice", "fd.playability", "fd.instrument", "waveguide", "models",
         "effects", "mix", "live", "rendering", "precompile", "testing"]
# the two physical models: neither may reach the other, directly or through any module it imports
MODELS = ("fd", "waveguide")


def _layer(module: str) -> str:
    """The layer of an engine module, by its dotted name below ``engine``."""
    parts = module.split(".")
    if parts[0] == "fd" and len(parts) > 1:
        return ".".join(parts[:2])
    return parts[0]


def _module(path: Path) -> str:
    """A file's dotted name below ``engine`` (a package by its own name)."""
    parts = list(path.relative_to(ENGINE).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _is_module(dotted: str) -> bool:
    base = ENGINE.joinpath(*dotted.split("."))
    return base.with_suffix(".py").is_file() or (base / "__init__.py").is_file()


def _engine_imports(path: Path) -> set[str]:
    """The engine modules a file imports anywhere in it (inside functions too; relative imports
    only inside the engine), by their dotted names below ``engine``."""
    tree = ast.parse(path.read_text())
    in_engine = path.is_relative_to(ENGINE)
    here = _module(path).split(".") if in_engine else []
    package = here if in_engine and path.stem == "__init__" else here[:-1]
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out.update(a.name[len("engine."):] for a in node.names if a.name.startswith("engine."))
            continue
        if not isinstance(node, ast.ImportFrom):
            continue
        if node.level == 0:
            if not (node.module == "engine" or (node.module or "").startswith("engine.")):
                continue
            base = node.module.split(".")[1:]
        elif not in_engine:
            continue
        else:
            base = package[:len(package) - node.level + 1] + (node.module or "").split(".")
            base = [b for b in base if b]
        for a in node.names:  # ``from . import kernels``: a module; ``from .x import y``: x
            sub = ".".join([*base, a.name])
            out.add(sub if _is_module(sub) else ".".join(base))
    out.discard("")
    return out


def _engine_files():
    for path in sorted(ENGINE.rglob("*.py")):
        if path.parent == ENGINE and path.stem == "__init__":
            continue  # the public names, imported on first use
        if path == ENGINE / "fd" / "__init__.py":
            continue  # a docstring
        yield path


def test_every_engine_module_imports_only_modules_below_it():
    layers = {_layer(_module(p)) for p in _engine_files()}
    assert layers == set(ORDER), f"missing from ORDER: {layers - set(ORDER)}, " \
        f"gone: {set(ORDER) - layers}"
    bad = []
    for path in _engine_files():
        name = _layer(_module(path))
        for dep in {_layer(d) for d in _engine_imports(path)} - {name}:
            if dep not in ORDER or ORDER.index(dep) > ORDER.index(name):
                bad.append(f"{path.relative_to(ROOT)} imports {dep}")
    assert not bad, bad


def _reach(module: str) -> set[str]:
    """Every engine module that importing ``module`` (a dotted name below ``engine``) runs: its
    imports, theirs, and so on (the packages around them too)."""
    seen, todo = set(), [module]
    while todo:
        name = todo.pop()
        parts = name.split(".")
        for i in range(1, len(parts) + 1):  # ``fd.string`` runs ``fd/__init__`` first
            prefix = ".".join(parts[:i])
            if prefix in seen or not _is_module(prefix):
                continue
            seen.add(prefix)
            base = ENGINE.joinpath(*prefix.split("."))
            path = base / "__init__.py" if (base / "__init__.py").is_file() else base.with_suffix(
                ".py")
            todo.extend(_engine_imports(path))
    return seen - {module}


def test_neither_model_reaches_the_other():
    """``fd`` and ``waveguide`` are siblings: no module of one imports the other's, directly nor
    through a module below them both that imports it (a shared module that needs one model's
    analysis is handed it from above: ``engine.models``)."""
    bad = []
    for path in _engine_files():
        name = _module(path)
        own = name.split(".")[0]
        if own not in MODELS:
            continue
        for dep in _reach(name):
            if dep.split(".")[0] in MODELS and dep.split(".")[0] != own:
                bad.append(f"{path.relative_to(ROOT)} reaches {dep}")
    assert not bad, bad


def test_no_model_is_told_apart_by_its_name_outside_models():
    """Code in the engine, the service and the CLI never compares a model's name: what differs
    between models is asked of ``engine.models`` (an instrument, ``TRAITS``) or of a table keyed
    by every name of ``engine.scene.MODELS``."""
    names = {"fdtd", "waveguide"}
    bad = []
    for path in [*ENGINE.rglob("*.py"), *(ROOT / "service").rglob("*.py"),
                 *(ROOT / "cli").rglob("*.py")]:
        if path == ENGINE / "models.py":
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Compare) and any(
                    isinstance(c, ast.Constant) and c.value in names
                    for c in [node.left, *node.comparators]):
                bad.append(f"{path.relative_to(ROOT)}:{node.lineno}")
    assert not bad, bad


def test_kernels_know_nothing_above_them():
    for path in (ENGINE / "fd" / "kernels").glob("*.py"):
        assert {_layer(d) for d in _engine_imports(path)} <= {"fd.kernels", "config"}, path


def test_validating_a_scene_loads_no_numerics():
    code = ("import sys, engine; engine.parse_scene({'duration': 1.0, 'events': ["
            "{'type': 'pluck', 'time': 0, 'string': 1}]}); "
            "engine.estimate_cost({'duration': 1.0, 'events': ["
            "{'type': 'fret', 'time': 0, 'string': 1, 'fret': 3}]}); "
            "print(sorted(m for m in ('numba', 'scipy', 'engine.fd.kernels') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], cwd=ROOT, capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "[]", out.stdout


def test_the_service_reaches_the_engine_through_its_public_names():
    for path in (ROOT / "service").rglob("*.py"):
        deps = _engine_imports(path)
        assert deps <= {"scene"}, f"{path.relative_to(ROOT)} imports engine internals {deps}"
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom) and node.module == "engine.scene":
                assert {a.name for a in node.names} <= {
                    "MAX_DURATION_S", "MAX_EVENTS", "SAMPLE_RATE_MAX", "SAMPLE_RATE_MIN"}, path


def test_the_rooms_beside_the_layers_know_only_what_they_need():
    """The score importers know only the scene's schema, the presets and the player's gestures
    (the two models' rooms: ``test_neither_model_reaches_the_other``)."""
    for path in (ENGINE / "score").glob("*.py"):
        deps = {_layer(d) for d in _engine_imports(path)} - {"score"}
        assert deps <= {"scene", "presets", "performance"}, path
