"""The whole suite's set-up: the numba kernels are loaded (or, on a fresh machine, compiled) once,
before the first test, and the time it took is its own line of the report instead of being billed
to whichever test happens to run first.  ``GUITAR_TEST_WARMUP=0`` leaves it out (a run of tests
that never render, such as ``tests/test_layers.py``).  Under pytest-xdist (``make test-fast``:
``-n 2``) each worker process warms up for itself (``engine.warmup`` lets one process compile at a
time and the others load what it cached) and reports its time to the controller, which prints
the longest."""

from __future__ import annotations

import os

import pytest

_WARMUP: dict[str, float] = {}


def pytest_collection_finish(session: pytest.Session) -> None:
    if os.environ.get("GUITAR_TEST_WARMUP", "1") == "0" or not session.items:
        return
    if session.config.getoption("collectonly"):
        return
    import engine

    _WARMUP["seconds"] = engine.warmup()
    if hasattr(session.config, "workeroutput"):  # a pytest-xdist worker: tell the controller
        session.config.workeroutput["warmup_s"] = _WARMUP["seconds"]


@pytest.hookimpl(optionalhook=True)
def pytest_testnodedown(node, error) -> None:
    """pytest-xdist's controller: a worker finished; keep the longest warm-up."""
    seconds = getattr(node, "workeroutput", {}).get("warmup_s")
    if seconds is not None:
        _WARMUP["seconds"] = max(_WARMUP.get("seconds", 0.0), seconds)


def pytest_terminal_summary(terminalreporter, exitstatus, config) -> None:
    if "seconds" in _WARMUP:
        where = os.environ.get("NUMBA_CACHE_DIR", "numba's default cache")
        terminalreporter.write_line(f"kernels loaded or compiled before the first test: "
                                    f"{_WARMUP['seconds']:.1f} s (cache: {where})")
