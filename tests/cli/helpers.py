"""Running the installed ``guitar-synth`` command as a user would: a subprocess."""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def command() -> str:
    """The installed console script: on PATH, or beside this interpreter (a venv's bin/)."""
    found = shutil.which("guitar-synth") or shutil.which(
        "guitar-synth", path=str(Path(sys.executable).parent))
    if found is None:
        raise AssertionError("the guitar-synth command is not installed: pip install -e .")
    return found


def run(*args: str | Path, timeout: float = 600.0, cwd: Path | None = None,
        env: dict[str, str] | None = None) -> subprocess.CompletedProcess:
    # The repository first on the path, so that this checkout's cli/engine are the ones run.
    path = os.pathsep.join(p for p in (str(ROOT), os.environ.get("PYTHONPATH")) if p)
    return subprocess.run([command(), *map(str, args)], capture_output=True, text=True,
                          timeout=timeout, cwd=cwd, env={**os.environ, "PYTHONPATH": path,
                                                         **(env or {})})


def one_error_line(r: subprocess.CompletedProcess) -> str:
    """The single line a failed command prints, after checking that it is one line and exit 2."""
    lines = r.stderr.strip().splitlines()
    assert r.returncode == 2, (r.returncode, r.stderr[-2000:])
    assert len(lines) == 1, r.stderr[-2000:]
    assert "Traceback" not in r.stderr
    assert r.stdout == ""
    return lines[0]
