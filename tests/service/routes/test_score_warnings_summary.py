"""`X-Score-Warnings-Summary`: a score's per-beat warnings grouped (one line per message and track,
with its bars), beside the per-beat `X-Score-Warnings`."""

from __future__ import annotations

import json
from pathlib import Path

import httpx
import pytest

DEMO = Path(__file__).resolve().parents[3] / ".cache" / "score-corpus" / "gp" / "Demo v5.gp5"


@pytest.mark.skipif(not DEMO.exists(), reason="score corpus missing: run `make test-data`")
def test_score_scene_sends_grouped_warnings(server) -> None:
    r = httpx.post(server.url + "/score/scene", files={"file": (DEMO.name, DEMO.read_bytes())},
                   timeout=120.0)
    assert r.status_code == 200, r.text[:300]
    every = json.loads(r.headers["X-Score-Warnings"])
    summary = json.loads(r.headers["X-Score-Warnings-Summary"])
    assert len(summary) < len(every)
    assert ("track 'Solo Guitar' (2): tremolo bar not playable (the engine bends strings only "
            "upwards), ignored: bars 22, 24, 46, 48 (6 beats)") in summary
    assert "track 'Percussions' (5): a percussion track, left out" in summary
