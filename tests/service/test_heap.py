"""The server's processes give freed memory back to the system (``service.heap``): glibc keeps
freed heap memory for reuse, and under the mixed load every process's resident memory crept up.
A render worker trims its heaps after every job (``service.worker._give_back_memory``); the API
process has its large blocks mapped on their own (``GUITAR_API_MMAP_THRESHOLD_KIB``)."""

from __future__ import annotations

import subprocess
import sys
import textwrap

import httpx
import pytest

from service import heap, worker

glibc = pytest.mark.skipif(not heap.available(), reason="glibc's malloc_trim and mallopt only")

# A heap with holes, as a mix of jobs leaves it: one large array freed (which raises glibc's
# threshold for serving large blocks from mappings of their own, as a song's arrays do), then
# 400 arrays of 256 KiB from the heap, every other one freed.  The freed half (50 MiB) lies
# between live blocks, where nothing returns it to the system by itself.
HOLES = textwrap.dedent("""
    import numpy as np
    from pathlib import Path
    from service import heap, worker

    def rss_mib():
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024

    {setup}
    big = np.ones(1 << 20)
    del big
    kept, freed = [], []
    for i in range(400):
        (kept if i % 2 else freed).append(np.ones(1 << 15))
    before = rss_mib()
    del freed
    {action}
    print(before - rss_mib())
""")


def _returned_mib(action: str, setup: str = "pass") -> float:
    out = subprocess.run([sys.executable, "-c", HOLES.format(action=action, setup=setup)],
                         check=True, capture_output=True, text=True, timeout=60).stdout
    return float(out.split()[-1])


@glibc
def test_the_memory_a_job_freed_between_live_blocks_goes_back_to_the_system() -> None:
    assert _returned_mib("pass") < 5.0  # glibc keeps the holes by itself
    assert _returned_mib("worker._give_back_memory()") > 40.0  # of the 50 MiB freed


@glibc
def test_with_large_blocks_mapped_on_their_own_freeing_them_returns_their_memory() -> None:
    """What the API process does at startup: with the threshold fixed below the blocks' size,
    the 8 MiB block freed first no longer raises it, every 256 KiB block is a mapping of its own,
    and freeing one unmaps it, without a trim."""
    assert _returned_mib("pass", setup="assert heap.map_large_blocks(128 * 1024)") > 40.0
    assert not heap.map_large_blocks(0)
    assert not heap.map_large_blocks(heap.MAX_MMAP_THRESHOLD + 1)


@glibc
def test_the_server_maps_its_large_blocks_on_their_own(server) -> None:
    """A real uvicorn with the default settings took the threshold (128 KiB) and says so."""
    text = httpx.get(server.url + "/metrics", timeout=10).text
    line = next(x for x in text.splitlines() if x.startswith("guitar_heap_mmap_threshold_bytes"))
    assert float(line.split()[-1]) == 128 * 1024


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
