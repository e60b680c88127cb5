"""A render worker gives the memory a job freed back to the system after the job (glibc keeps
freed heap memory for reuse, and under a mix of songs a worker's resident memory crept up job
after job: ``service.worker._give_back_memory``)."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import pytest

from service import worker

glibc = pytest.mark.skipif(worker._MALLOC_TRIM is None, reason="glibc's malloc_trim only")

# A heap with holes, as a mix of jobs leaves it: one large array freed (which raises glibc's
# threshold for serving large blocks from mappings of their own, as a song's arrays do), then
# 400 arrays of 256 KiB from the heap, every other one freed.  The freed half (50 MiB) lies
# between live blocks, where nothing returns it to the system by itself.
HOLES = textwrap.dedent("""
    import numpy as np
    from pathlib import Path
    from service import worker

    def rss_mib():
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024

    big = np.ones(1 << 20)
    del big
    kept, freed = [], []
    for i in range(400):
        (kept if i % 2 else freed).append(np.ones(1 << 15))
    del freed
    before = rss_mib()
    {action}
    print(before - rss_mib())
""")


def _returned_mib(action: str) -> float:
    out = subprocess.run([sys.executable, "-c", HOLES.format(action=action)], check=True,
                         capture_output=True, text=True, timeout=60).stdout
    return float(out.split()[-1])


@glibc
def test_the_memory_a_job_freed_between_live_blocks_goes_back_to_the_system() -> None:
    assert _returned_mib("pass") < 5.0  # glibc keeps the holes by itself
    assert _returned_mib("worker._give_back_memory()") > 40.0  # of the 50 MiB freed


class _Conn:
    """A worker's pipe that hands out ``messages`` and keeps what the worker sends."""

    def __init__(self, messages: list) -> None:
        self.messages, self.sent = list(messages), []

    def recv(self):
        return self.messages.pop(0)

    def poll(self) -> bool:
        return False

    def send(self, msg) -> None:
        self.sent.append(msg)


def test_the_worker_gives_memory_back_after_every_job_done_or_failed(monkeypatch) -> None:
    calls = []
    monkeypatch.setattr(worker, "_give_back_memory", lambda: calls.append(len(conn.sent)))
    bad = {"scene": b"{not json", "sample_rate": 44100, "format": "wav", "subtype": "PCM_16",
           "channels": 1}
    conn = _Conn([("labels", 1, {"scene": {"duration": 0.05, "events": []}}),
                  ("render", 2, bad), ("cancel", 3), None])
    import engine

    worker._serve(conn, engine, block_frames=1024)
    assert [m[0] for m in conn.sent] == ["done", "error"]
    assert calls == [1, 2]  # after each job's answer; a stale cancel is no job
