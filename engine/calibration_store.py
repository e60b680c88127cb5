"""Fret calibrations kept on disk, so that a machine calibrates a string's frets once, not every
process once.

``engine.fd.intonation`` calibrates each stopped fret on its string's grid (the pitch, and the
contact damping of the finger stopping it) with a few eigenvalue solves of the held note: tens of
milliseconds a fret, seconds for every fret of a guitar (the grid of a live session).  The
waveguide model asks the same held-note analysis, on the converged grid, for the finger's damping
of each held fret (``engine.waveguide.fingering.finger_decay_db_s``): seconds for every fret of
a guitar too (``benchmarks/calibration.py`` prints both).  A result depends
only on its inputs (the string model, or the preset, string and rate; the fret) and on the code
that computes it, so it is kept in a SQLite file under ``config.CACHE_DIR``, keyed by a hash of
both: a changed input or a changed module computes anew.  The values are stored as written by
``repr``, which gives each float back to the last bit, so a render is the same with the store or
without it (``tests/engine/test_calibration_store.py``).  Reading and writing are best effort: an
unwritable, locked or damaged file leaves the calibration computed in memory, as without the
store.
"""

from __future__ import annotations

import hashlib
import json
import os
import sqlite3
import threading
from pathlib import Path

from . import config

# the modules whose code a calibration depends on (the held-note model, the grid and tuning,
# where fingers and frets sit, the presets, the interpolant)
_SOURCES = ("fd/intonation.py", "fd/string.py", "fd/grid.py", "losses.py", "fd/controls.py",
            "performance.py", "presets.py", "fd/kernels/linear.py")
_LOCK = threading.Lock()
_STATE: dict = {}
_LOCAL = threading.local()  # per thread: the on_compute callback


def _version(sources: tuple[str, ...] = ()) -> str:
    """A hash of the source of ``_SOURCES`` and ``sources`` (more modules, relative to the
    engine's folder, that compute a kind of calibration) and of the numpy and scipy versions (the
    eigenvalue solves are theirs): the code part of every key."""
    name = ("version", sources)
    if name not in _STATE:
        import numpy
        import scipy

        h = hashlib.sha256(f"numpy {numpy.__version__} scipy {scipy.__version__}".encode())
        root = Path(__file__).resolve().parent
        for src in _SOURCES + sources:
            h.update((root / src).read_bytes())
        _STATE[name] = h.hexdigest()
    return _STATE[name]


def key(kind: str, *inputs, sources: tuple[str, ...] = ()) -> str:
    """The key of a calibration of ``kind`` from ``inputs`` (frozen dataclasses and numbers, whose
    ``repr`` is exact) computed by ``_SOURCES`` and ``sources``."""
    return hashlib.sha256(repr((_version(sources), kind, inputs)).encode()).hexdigest()


def _connection() -> sqlite3.Connection | None:
    if "db" not in _STATE or _STATE.get("pid") != os.getpid():  # not across a fork
        _STATE["pid"] = os.getpid()
        _STATE["db"] = None
        if config.CALIBRATION_CACHE:
            try:
                path = Path(config.CACHE_DIR)
                path.mkdir(parents=True, exist_ok=True)
                db = sqlite3.connect(path / "calibrations.sqlite3", timeout=5.0,
                                     check_same_thread=False)
                db.execute("CREATE TABLE IF NOT EXISTS calibration "
                           "(key TEXT PRIMARY KEY, value TEXT NOT NULL)")
                db.commit()
                _STATE["db"] = db
            except (OSError, sqlite3.Error):
                pass
    return _STATE["db"]


def load(k: str) -> tuple[float, ...] | None:
    """The stored values of key ``k``, or None (not stored, or the store cannot be read)."""
    with _LOCK:
        db = _connection()
        if db is None:
            return None
        try:
            row = db.execute("SELECT value FROM calibration WHERE key = ?", (k,)).fetchone()
            return None if row is None else tuple(float(v) for v in json.loads(row[0]))
        except (sqlite3.Error, ValueError, TypeError):
            return None


def save(k: str, values: tuple[float, ...]) -> None:
    """Keep ``values`` under key ``k`` (nothing happens if the store cannot be written)."""
    with _LOCK:
        db = _connection()
        if db is None:
            return
        try:
            db.execute("INSERT OR REPLACE INTO calibration VALUES (?, ?)",
                       (k, json.dumps([float(v) for v in values])))
            db.commit()
        except sqlite3.Error:
            pass


def on_compute(callback) -> None:
    """Call ``callback(kind)`` (or nothing, for None) in this thread whenever a calibration is
    computed because the store does not hold it: the CLI says "calibrating frets" then."""
    _LOCAL.callback = callback


def recall(kind: str, inputs: tuple, compute, sources: tuple[str, ...] = ()) -> tuple[float, ...]:
    """The values of a calibration of ``kind`` from ``inputs``: read from the store, or
    ``compute()`` (numbers) and kept.  Python floats either way: a value computed as numpy's
    float64 would ``repr`` otherwise than the same value read back, and so would the key of a
    calibration that takes it as an input (a tuned string's).  ``sources``: the modules beyond
    ``_SOURCES`` whose code computes it (``key``)."""
    k = key(kind, *inputs, sources=sources)
    stored = load(k)
    if stored is not None:
        return stored
    callback = getattr(_LOCAL, "callback", None)
    if callback is not None:
        callback(kind)
    values = tuple(float(v) for v in compute())
    save(k, values)
    return values


def reset() -> None:
    """Forget the connection (the next use opens ``config.CACHE_DIR`` again): for tests."""
    with _LOCK:
        db = _STATE.pop("db", None)
        if db is not None:
            db.close()
