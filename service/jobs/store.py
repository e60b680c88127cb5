"""The job store: one SQLite file (stdlib ``sqlite3``) and a folder of results per job.

    DATA_DIR/jobs.sqlite3          the jobs table
    DATA_DIR/results/ID/audio.EXT  written as audio.EXT.part, renamed when complete
    DATA_DIR/results/ID/labels.jams

A job is ``done`` only after its audio file has been renamed into place, so a file that a crash
cut short is never served.  The database runs in WAL mode: a commit survives the death of the
process (not necessarily a power cut: ``synchronous=NORMAL``).  Every call is short and runs on
the event loop, serialised by a lock (the runner and the routes share one connection); none of
them syncs the disk: the WAL is copied into the database (and the file synced) by ``checkpoint``,
which the runner calls from a thread once a minute, not by SQLite's automatic checkpoint inside
whichever commit filled the WAL (on the loop, for as long as the disk took).
"""

from __future__ import annotations

import json
import shutil
import sqlite3
import threading
import time
import uuid
from pathlib import Path
from typing import Any

STATUSES = ("queued", "running", "done", "failed", "cancelled")
FINISHED = ("done", "failed", "cancelled")

_SCHEMA = """
CREATE TABLE IF NOT EXISTS jobs (
    id TEXT PRIMARY KEY,
    status TEXT NOT NULL,
    progress REAL NOT NULL DEFAULT 0,
    created REAL NOT NULL,
    started REAL,
    finished REAL,
    attempts INTEGER NOT NULL DEFAULT 0,
    scene TEXT NOT NULL,
    format TEXT NOT NULL,
    duration REAL NOT NULL,
    audio_seconds REAL,
    render_seconds REAL,
    error TEXT,
    warnings TEXT NOT NULL DEFAULT '[]',
    labels INTEGER NOT NULL DEFAULT 0,
    labels_error TEXT
);
CREATE INDEX IF NOT EXISTS jobs_status_created ON jobs (status, created);
"""
# Columns added after the first release: a database made before gets them at start-up.
_ADDED = {"cost": "REAL", "client": "TEXT", "stems": "INTEGER NOT NULL DEFAULT 0"}

# Fair share: a queued job's turn is ordered by what its client has been served (the estimated
# seconds of its jobs running now or started within this window) plus the job's own estimate.
FAIR_WINDOW_S = 3600.0


class Store:
    def __init__(self, data_dir: str | Path):
        self.root = Path(data_dir)
        self.results = self.root / "results"
        self.results.mkdir(parents=True, exist_ok=True)
        self._lock = threading.Lock()
        self._db = sqlite3.connect(self.root / "jobs.sqlite3", check_same_thread=False,
                                   isolation_level=None)
        self._db.row_factory = sqlite3.Row
        with self._lock:
            self._db.execute("PRAGMA journal_mode=WAL")
            self._db.execute("PRAGMA synchronous=NORMAL")
            self._db.execute("PRAGMA wal_autocheckpoint=0")  # ``checkpoint``, off the loop
            self._db.executescript(_SCHEMA)
            have = {r[1] for r in self._db.execute("PRAGMA table_info(jobs)")}
            for column, kind in _ADDED.items():
                if column not in have:
                    self._db.execute(f"ALTER TABLE jobs ADD COLUMN {column} {kind}")
            self._db.execute("CREATE INDEX IF NOT EXISTS jobs_client ON jobs (client, started)")

    def checkpoint(self) -> tuple[int, int, int]:
        """Copy the WAL into the database on a connection of its own (a thread may call it while
        the loop uses the store: PASSIVE waits for no reader or writer).  Returns SQLite's
        (busy, WAL frames, frames checkpointed)."""
        db = sqlite3.connect(self.root / "jobs.sqlite3", isolation_level=None)
        try:
            return tuple(db.execute("PRAGMA wal_checkpoint(PASSIVE)").fetchone())
        finally:
            db.close()

    def close(self) -> None:
        with self._lock:
            self._db.close()

    # ---- reading ------------------------------------------------------------------------------

    def get(self, job_id: str) -> dict[str, Any] | None:
        with self._lock:
            row = self._db.execute("SELECT * FROM jobs WHERE id = ?", (job_id,)).fetchone()
        return dict(row) if row else None

    def counts(self) -> dict[str, int]:
        with self._lock:
            rows = self._db.execute("SELECT status, COUNT(*) FROM jobs GROUP BY status").fetchall()
        out = dict.fromkeys(STATUSES, 0)
        out.update({r[0]: r[1] for r in rows})
        return out

    def job_dir(self, job_id: str) -> Path:
        return self.results / job_id

    def audio_path(self, job: dict[str, Any]) -> Path:
        return self.job_dir(job["id"]) / f"audio.{job['format']}"

    def labels_path(self, job_id: str) -> Path:
        return self.job_dir(job_id) / "labels.jams"

    def stems_path(self, job_id: str) -> Path:
        return self.job_dir(job_id) / "stems.zip"

    # ---- writing ------------------------------------------------------------------------------

    def create(self, scene: dict[str, Any] | str, fmt: str, duration: float,
               cost: float | None = None, client: str | None = None,
               stems: bool | None = None) -> dict[str, Any]:
        """A queued job of ``scene`` (a dict, or its JSON with ``stems`` said); ``cost`` is its
        estimated render seconds, ``client`` who asked for it."""
        job_id = uuid.uuid4().hex
        if stems is None:
            d = json.loads(scene) if isinstance(scene, str) else scene
            stems = bool((d.get("output") or {}).get("stems"))
        text = scene if isinstance(scene, str) else json.dumps(scene)
        with self._lock:
            self._db.execute(
                "INSERT INTO jobs (id, status, created, scene, format, duration, cost, client, "
                "stems) VALUES (?, 'queued', ?, ?, ?, ?, ?, ?, ?)",
                (job_id, time.time(), text, fmt, duration, cost, client, int(stems)))
        job = self.get(job_id)
        assert job is not None
        return job

    def unfinished(self, client: str | None) -> int:
        """Jobs of ``client`` queued or running."""
        with self._lock:
            return self._db.execute(
                "SELECT COUNT(*) FROM jobs WHERE client IS ? AND status IN ('queued', 'running')",
                (client,)).fetchone()[0]

    def claim_next(self) -> dict[str, Any] | None:
        """The next queued job by fair share, now ``running`` with one more attempt
        (atomically): the one whose client has been served least (the estimated seconds of its
        jobs running or started within ``FAIR_WINDOW_S``) plus its own estimate, then the
        oldest.  One client's many or long jobs thus wait while another's short ones run, and
        every job's turn comes once the others have been served as much."""
        now = time.time()
        with self._lock:
            row = self._db.execute(
                "UPDATE jobs SET status = 'running', started = ?, progress = 0, "
                "attempts = attempts + 1 WHERE id = ("
                "  SELECT q.id FROM jobs q WHERE q.status = 'queued' ORDER BY"
                "  (SELECT COALESCE(SUM(COALESCE(r.cost, 0)), 0) FROM jobs r"
                "   WHERE r.client IS q.client AND r.id != q.id"
                "   AND (r.status = 'running' OR r.started > ?)) + COALESCE(q.cost, 0),"
                "  q.created LIMIT 1) RETURNING *", (now, now - FAIR_WINDOW_S)).fetchone()
        return dict(row) if row else None

    def set_progress(self, job_id: str, progress: float) -> None:
        with self._lock:
            self._db.execute("UPDATE jobs SET progress = ? WHERE id = ? AND status = 'running'",
                             (progress, job_id))

    def finish(self, job_id: str, status: str, **fields: Any) -> None:
        """Set a running job's final status (a job cancelled meanwhile stays cancelled)."""
        assert status in FINISHED
        if "warnings" in fields:
            fields["warnings"] = json.dumps(fields["warnings"])
        sets = ", ".join(f"{k} = ?" for k in fields)
        sets = f", {sets}" if sets else ""
        with self._lock:
            self._db.execute(
                f"UPDATE jobs SET status = ?, finished = ?{sets} "
                "WHERE id = ? AND status = 'running'",
                (status, time.time(), *fields.values(), job_id))

    def requeue(self, job_id: str, count_attempt: bool) -> None:
        """A running job goes back to the queue (shutdown, or a worker that died under it)."""
        undo = "" if count_attempt else ", attempts = attempts - 1"
        with self._lock:
            self._db.execute(f"UPDATE jobs SET status = 'queued', progress = 0{undo} "
                             "WHERE id = ? AND status = 'running'", (job_id,))

    def recover(self, max_attempts: int) -> tuple[int, int]:
        """At start-up: jobs left ``running`` by a process that died are queued again, unless
        they have been cut off ``max_attempts`` times (a scene that kills its server must not
        kill every restart).  Returns (requeued, failed)."""
        now = time.time()
        with self._lock:
            failed = self._db.execute(
                "UPDATE jobs SET status = 'failed', finished = ?, error = 'the job was cut off "
                "by a restart or a dead worker ' || attempts || ' times' "
                "WHERE status = 'running' AND attempts >= ?", (now, max_attempts)).rowcount
            requeued = self._db.execute(
                "UPDATE jobs SET status = 'queued', progress = 0 WHERE status = 'running'"
            ).rowcount
        return requeued, failed

    def cancel(self, job_id: str) -> str | None:
        """Cancel a queued or running job; returns its status before (None: unknown id)."""
        with self._lock:
            row = self._db.execute("SELECT status FROM jobs WHERE id = ?", (job_id,)).fetchone()
            if row is None:
                return None
            if row[0] in ("queued", "running"):
                self._db.execute("UPDATE jobs SET status = 'cancelled', finished = ? "
                                 "WHERE id = ?", (time.time(), job_id))
        return row[0]

    def delete(self, job_id: str) -> None:
        with self._lock:
            self._db.execute("DELETE FROM jobs WHERE id = ?", (job_id,))
        shutil.rmtree(self.job_dir(job_id), ignore_errors=True)

    def cleanup(self, retention_s: float, max_jobs: int) -> list[str]:
        """Delete finished jobs older than ``retention_s`` and, beyond ``max_jobs`` jobs in all,
        the oldest finished ones.  Returns the ids deleted."""
        with self._lock:
            old = [r[0] for r in self._db.execute(
                "SELECT id FROM jobs WHERE status IN ('done', 'failed', 'cancelled') "
                "AND finished < ?", (time.time() - retention_s,))]
            total = self._db.execute("SELECT COUNT(*) FROM jobs").fetchone()[0] - len(old)
            excess = max(0, total - max_jobs)
            if excess:
                old += [r[0] for r in self._db.execute(
                    "SELECT id FROM jobs WHERE status IN ('done', 'failed', 'cancelled') "
                    f"AND id NOT IN ({','.join('?' * len(old))}) ORDER BY finished LIMIT ?",
                    (*old, excess))]
        for job_id in old:
            self.delete(job_id)
        # result folders whose job is gone (a crash between the two steps of a delete)
        with self._lock:
            known = {r[0] for r in self._db.execute("SELECT id FROM jobs")}
        for d in self.results.iterdir():
            if d.is_dir() and d.name not in known:
                shutil.rmtree(d, ignore_errors=True)
        return old

    def total(self) -> int:
        with self._lock:
            return self._db.execute("SELECT COUNT(*) FROM jobs").fetchone()[0]
