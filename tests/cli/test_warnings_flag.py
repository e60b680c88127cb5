"""`guitar-synth scene/render --warnings summary|all|none`: what cannot be played, grouped by
default (engine/score/warnings.py), every beat on request, or nothing."""

from __future__ import annotations

from pathlib import Path

import pytest

from .helpers import run

DEMO = Path(__file__).resolve().parents[2] / ".cache" / "score-corpus" / "gp" / "Demo v5.gp5"


def _warning_lines(r) -> list[str]:
    assert r.returncode == 0, r.stderr
    return [line for line in r.stderr.splitlines() if line.startswith("warning: ")]


@pytest.mark.skipif(not DEMO.exists(), reason="score corpus missing: run `make test-data`")
def test_warnings_summary_all_none(tmp_path: Path) -> None:
    out = tmp_path / "scene.json"
    summary = _warning_lines(run("scene", DEMO, "-o", out))
    every = _warning_lines(run("scene", DEMO, "-o", out, "--warnings", "all"))
    assert _warning_lines(run("scene", DEMO, "-o", out, "--warnings", "none")) == []
    assert len(summary) < len(every)
    assert ("warning: track 'Solo Guitar' (2): tremolo bar not playable (the engine bends strings "
            "only upwards), ignored: bars 22, 24, 46, 48 (6 beats)") in summary
    assert any(line.startswith("warning: bar 22, beat 1, track 'Solo Guitar' (2): tremolo bar")
               for line in every)
    bad = run("scene", DEMO, "-o", out, "--warnings", "some")
    assert bad.returncode != 0 and "--warnings" in bad.stderr
