"""`make serve` listens where HOST= and PORT= say (default 127.0.0.1:8000), as the README's Quick
start tells. Checked with `make -n` (what make would run), so nothing is installed or served."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _serve_command(*args: str) -> str:
    out = subprocess.run(["make", "-n", "-C", str(ROOT), "serve", *args], capture_output=True,
                         text=True, check=True).stdout
    return next(line for line in out.splitlines() if "uvicorn service.app:app" in line)


@pytest.mark.skipif(shutil.which("make") is None, reason="make is not installed")
def test_make_serve_takes_host_and_port() -> None:
    assert "--host 127.0.0.1 --port 8000" in _serve_command()
    assert "--host 0.0.0.0 --port 8123" in _serve_command("HOST=0.0.0.0", "PORT=8123")
    assert "make serve HOST=" in (ROOT / "README.md").read_text()
