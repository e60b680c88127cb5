"""The layers of docs/architecture.md, as the imports say them: every engine module imports only
modules below it, the schema loads no numerics, and the service reaches the engine only through
its public package (and the schema's limits)."""

from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

# low to high, as engine/__init__.py lists them; a module may import only those before it
ORDER = ["config", "presets", "effect_specs", "scene", "live_events", "grid", "cost", "kernels",
         "string", "controls", "calibration_store", "intonation", "options", "output", "voice",
         "playability", "guitar", "waveguide", "effects", "mix", "live", "rendering",
         "precompile"]


def _engine_imports(path: Path) -> set[str]:
    """The engine modules a file imports (relative ones only inside the engine), by their name
    below ``engine``."""
    tree = ast.parse(path.read_text())
    sub = path.parent.name if path.parent.parent.name == "engine" else None  # kernels, score ...
    in_engine = "engine" in path.relative_to(ROOT).parts[:1]
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom):
            if node.level == 0 and node.module and node.module.startswith("engine."):
                out.add(node.module.split(".")[1])
            elif not in_engine:
                continue
            elif node.level == 1 and sub:
                out.add(sub)  # a module of the same subpackage
            elif node.level == 1 and node.module:
                out.add(node.module.split(".")[0])
            elif node.level == 1:
                out.update(a.name for a in node.names)
            elif node.level == 2 and node.module:
                out.add(node.module.split(".")[0])
            elif node.level == 2:
                out.update(a.name for a in node.names)
        elif isinstance(node, ast.Import):
            out.update(a.name.split(".")[1] for a in node.names if a.name.startswith("engine."))
    return out


def test_every_engine_module_imports_only_modules_below_it():
    listed = {p.stem for p in (ROOT / "engine").glob("*.py")} - {"__init__", "analysis"}
    assert listed | {"kernels", "waveguide"} == set(ORDER), "a module is missing from the list"
    bad = []
    for path in [*(ROOT / "engine").glob("*.py"), *(ROOT / "engine" / "kernels").glob("*.py")]:
        name = "kernels" if path.parent.name == "kernels" else path.stem
        if name in ("__init__", "analysis"):
            continue
        for dep in _engine_imports(path) - {name}:
            if dep not in ORDER or ORDER.index(dep) > ORDER.index(name):
                bad.append(f"{path.relative_to(ROOT)} imports {dep}")
    assert not bad, bad


def test_kernels_know_nothing_above_them():
    for path in (ROOT / "engine" / "kernels").glob("*.py"):
        assert _engine_imports(path) <= {"kernels", "config"}, path


def test_validating_a_scene_loads_no_numerics():
    code = ("import sys, engine; engine.parse_scene({'duration': 1.0, 'events': ["
            "{'type': 'pluck', 'time': 0, 'string': 1}]}); "
            "engine.estimate_cost({'duration': 1.0, 'events': ["
            "{'type': 'fret', 'time': 0, 'string': 1, 'fret': 3}]}); "
            "print(sorted(m for m in ('numba', 'scipy', 'engine.kernels') if m in sys.modules))")
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
    """The waveguide model sits beside the finite-difference guitar (``mix`` picks one per
    track): it may use what the guitar uses, nothing above.  The score importers know only the
    scene's schema and the presets."""
    below_mix = set(ORDER[:ORDER.index("waveguide")])
    for path in (ROOT / "engine" / "waveguide").glob("*.py"):
        assert _engine_imports(path) - {"waveguide"} <= below_mix, path
    for path in (ROOT / "engine" / "score").glob("*.py"):
        assert _engine_imports(path) - {"score"} <= {"scene", "presets"}, path
