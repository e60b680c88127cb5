"""The demo page's score player in a real browser (Debian's chromium, Playwright, uvicorn): open a
Guitar Pro file, choose a track, render, play, and see which note sounds on which string and fret.

Skipped (with the reason) where chromium or the playwright package is missing; never downloads a
browser of its own.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from browser import AUDIO_ARGS, LIT_PIXELS_JS, demo_page, require_browser
from conftest import UvicornServer

from tests.score_files import small_gp5, truncated_gp5

sync_api = require_browser()


@pytest.fixture(scope="module")
def page(server: UvicornServer) -> Iterator[Any]:
    with demo_page(sync_api, server.url, height=1400, extra_args=tuple(AUDIO_ARGS)) as pg:
        yield pg


def _open(page: Any, name: str, data: bytes) -> None:
    page.set_input_files("#score-file", files=[
        {"name": name, "mimeType": "application/octet-stream", "buffer": data}])


def _point(page: Any, t: float, pitch: float) -> tuple[float, float]:
    """Where on the piano roll (page coordinates) a note of ``pitch`` at time ``t`` is drawn."""
    return page.evaluate("""([t, p]) => {
      const c = document.querySelector('#score-roll'), r = c.getBoundingClientRect();
      const s = window.scorePlayer.state, ps = s.notes.map(n => n.pitch);
      const lo = Math.floor(Math.min(...ps)) - 1, hi = Math.ceil(Math.max(...ps)) + 2;
      const row = r.height / (hi - lo);
      return [r.left + t / s.duration * r.width, r.top + r.height - (p - lo + 0.5) * row];
    }""", [t, pitch])


def test_open_choose_render_play_and_see_the_notes(page: Any, tmp_path: Path) -> None:
    _open(page, "song.gp5", small_gp5())
    page.wait_for_selector("#score-roll[data-drawn='1']", timeout=60_000)
    names = page.eval_on_selector_all("#score-tracks input", "bs => bs.map(b => b.value)")
    assert names == ["Track 1", "Track 2"]
    assert "2 tracks, 8 notes" in page.inner_text("#score-status")  # the labels of both tracks

    page.uncheck("#score-tracks input[value='Track 2']")
    page.fill("#score-seconds", "2.5")
    page.click("#score-render")
    page.wait_for_selector("#score-waveform[data-drawn='1']", timeout=120_000)
    page.wait_for_function("document.querySelector('#score-audio').readyState >= 1",
                           timeout=30_000)
    audio = page.evaluate("""() => { const a = document.querySelector('#score-audio');
        return {src: a.src, duration: a.duration, error: a.error && a.error.code}; }""")
    assert audio["src"].startswith("blob:") and audio["error"] is None
    assert audio["duration"] == pytest.approx(2.5, abs=0.01)
    assert page.get_attribute("#score-roll", "data-notes") == "4"  # one track's four notes
    assert page.evaluate(LIT_PIXELS_JS, "#score-waveform") > 0.05
    assert page.evaluate(LIT_PIXELS_JS, "#score-roll") > 0.02
    assert page.inner_text("#score-error") == ""

    # Hovering the first note names its string and fret (D4: string 2, fret 3).
    page.mouse.move(*_point(page, 0.25, 62))
    assert "D4 (MIDI 62.00)" in page.inner_text("#score-note")
    assert "string 2, fret 3" in page.inner_text("#score-note")

    # Playing: the playhead moves and the note sounding now is named (E4, the open string 1).
    page.evaluate("() => { const a = document.querySelector('#score-audio'); a.muted = true; "
                  "a.currentTime = 1.2; return a.play(); }")
    page.wait_for_function("!document.querySelector('#score-audio').paused", timeout=10_000)
    page.wait_for_function("document.querySelector('#score-audio').currentTime > 1.25",
                           timeout=10_000)
    assert "E4 (s1 f0)" in page.inner_text("#score-now")
    left = page.evaluate("parseFloat(document.querySelector('#score-playhead').style.left)")
    assert 45 < left < 100
    page.evaluate("document.querySelector('#score-audio').pause()")
    page.screenshot(path=str(tmp_path / "score.png"), full_page=True)
    assert page.errors == []


def test_a_score_renders_on_the_waveguide(page: Any) -> None:
    """The score card's model select goes into the render's options."""
    _open(page, "song.gp5", small_gp5())
    page.wait_for_selector("#score-roll[data-drawn='1']", timeout=60_000)
    page.select_option("#score-model", "waveguide")
    assert page.is_disabled("#score-quality")
    page.fill("#score-seconds", "1.5")
    # the request's options, read from its form (a multipart body with a file is not exposed
    # by the browser's request events)
    page.evaluate("""() => { const f = window.fetch; window.sentOptions = [];
        window.fetch = (url, init) => { if (init && init.body instanceof FormData)
            window.sentOptions.push([url, init.body.get("options")]); return f(url, init); }; }""")
    before = page.evaluate("document.querySelector('#score-audio').src")
    page.click("#score-render")  # the scene and labels first, then the audio
    page.wait_for_function("window.sentOptions.some(([u]) => u === '/render/score')",
                           timeout=60_000)
    sent = dict(page.evaluate("window.sentOptions"))
    assert json.loads(sent["/render/score"])["model"] == "waveguide"
    page.wait_for_function("""(before) => { const a = document.querySelector('#score-audio');
        return a.src !== before && a.readyState >= 1; }""", arg=before, timeout=60_000)
    assert page.evaluate("document.querySelector('#score-audio').duration") == pytest.approx(
        1.5, abs=0.01)
    page.select_option("#score-model", "fdtd")
    assert page.inner_text("#score-error") == ""
    assert page.errors == []


def test_a_bad_file_is_named_on_the_page(page: Any) -> None:
    _open(page, "broken.gp5", truncated_gp5())
    page.wait_for_function("document.querySelector('#score-error').textContent.length > 0",
                           timeout=30_000)
    assert "broken.gp5: Guitar Pro file is truncated" in page.inner_text("#score-error")
    assert page.is_disabled("#score-render")
    assert page.errors == []
