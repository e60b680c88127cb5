"""A whole multi-track song in the demo page's score player (Debian's chromium, Playwright,
uvicorn): the longest multi-track Guitar Pro file of PyGuitarPro's corpus, longer than one render
request may be, is rendered as a job with its progress shown, plays, the tablature's cursor
follows the audio, a click on the tab seeks; no page or console error. Takes a screenshot of the
tab view; ``GUITAR_SCREENSHOT_DIR=docs/img`` keeps it there (docs/img/score-tab.png is one), else
it goes to the test's temporary folder, so a test run leaves the working tree as it was.

Skipped where chromium, playwright or the score corpus (`make test-data`) is missing.
"""

from __future__ import annotations

import os
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from browser import ARGS, AUDIO_ARGS, CHROMIUM, require_browser
from conftest import ROOT, UvicornServer

sync_api = require_browser()

SONG = ROOT / ".cache" / "score-corpus" / "gp" / "Demo v5.gp5"  # 49 bars, 5 tracks, 91 s
SHOT_NAME = "score-tab.png"

pytestmark = pytest.mark.skipif(not SONG.exists(), reason="score corpus missing: make test-data")


@pytest.fixture(scope="module")
def page(server: UvicornServer) -> Iterator[Any]:
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=[*ARGS, *AUDIO_ARGS])
        pg = browser.new_page(viewport={"width": 1300, "height": 1000})
        pg.errors = []
        pg.on("pageerror", lambda e: pg.errors.append(str(e)))
        pg.on("console", lambda m: pg.errors.append(m.text) if m.type == "error" else None)
        pg.goto(server.url + "/")
        pg.wait_for_selector("body[data-ready='1']", timeout=30_000)
        yield pg
        browser.close()


def _audio_time(page: Any) -> float:
    return page.evaluate("document.querySelector('#score-audio').currentTime")


def test_a_whole_song_renders_plays_and_the_tab_follows(page: Any, tmp_path: Path) -> None:
    page.set_input_files("#score-file", str(SONG))
    page.wait_for_selector("#tab[data-drawn='1']", timeout=120_000)
    status = page.inner_text("#score-status")
    assert "3 tracks" in status and "(91.0 s)" in status, status  # drums and the choir left out
    # the grouped warnings: one line per message and track
    warnings = page.eval_on_selector_all("#score-warnings li", "els => els.map(e => e.textContent)")
    assert any("bars 22, 24, 46, 48 (6 beats)" in w for w in warnings), warnings
    assert page.eval_on_selector_all("#tab-track option", "os => os.map(o => o.textContent)") \
        == ["Rhythm Guitar", "Solo Guitar", "Bass"]

    # "First seconds" changes the length the page says
    page.fill("#score-seconds", "20")
    page.dispatch_event("#score-seconds", "change")
    page.wait_for_function("document.querySelector('#score-status').textContent.includes('(20.0 s)')",
                           timeout=60_000)
    page.fill("#score-seconds", "")
    page.dispatch_event("#score-seconds", "change")
    page.wait_for_function("document.querySelector('#score-status').textContent.includes('(91.0 s)')",
                           timeout=60_000)

    # longer than one request may render: a job, with its progress
    page.select_option("#score-model", "waveguide")
    page.click("#score-render")
    page.wait_for_selector("#score-progress:not([hidden])", timeout=60_000)
    page.wait_for_function("document.querySelector('#score-audio').readyState >= 1",
                           timeout=600_000)
    assert page.evaluate("document.querySelector('#score-audio').duration") == pytest.approx(
        90.95, abs=0.05)
    assert page.inner_text("#score-error") == ""
    for link in ("#score-dl-audio", "#score-dl-labels", "#score-dl-scene"):
        assert page.is_visible(link), link

    # play: the audio clock advances within 5 s and the tab's cursor with it
    page.select_option("#tab-track", "1")  # the solo
    start = time.monotonic()
    page.evaluate("() => { const a = document.querySelector('#score-audio'); a.muted = true; "
                  "a.currentTime = 40; return a.play(); }")
    page.wait_for_function("document.querySelector('#score-audio').currentTime > 40.5",
                           timeout=5_000)
    assert time.monotonic() - start < 5.0
    page.wait_for_function("Number(document.querySelector('#tab').dataset.time) > 40.5",
                           timeout=5_000)
    t_tab = float(page.get_attribute("#tab", "data-time"))
    assert abs(t_tab - _audio_time(page)) < 0.5
    # the cursor stays in view: the box scrolled to it
    scroll = page.evaluate("document.querySelector('#tab-box').scrollLeft")
    pps = page.evaluate("window.scorePlayer.state.tab.pxPerSecond")
    width = page.evaluate("document.querySelector('#tab-box').clientWidth")
    assert scroll <= 20 + t_tab * pps <= scroll + width
    page.evaluate("document.querySelector('#score-audio').pause()")
    page.wait_for_timeout(200)
    shot = Path(os.environ.get("GUITAR_SCREENSHOT_DIR") or tmp_path) / SHOT_NAME
    shot.parent.mkdir(parents=True, exist_ok=True)
    # the page's pixels where the box is (an element screenshot re-lays the box out, scrolled home)
    page.screenshot(path=str(shot), clip=page.locator(".tab-box").bounding_box())
    assert shot.stat().st_size < 150_000

    # click the tab: the audio seeks to the time under the click
    box = page.locator("#tab").bounding_box()
    want = page.evaluate("(x) => window.scorePlayer.state.tab.timeAt(x)", box["width"] * 0.6)
    page.mouse.click(box["x"] + box["width"] * 0.6, box["y"] + box["height"] / 2)
    assert _audio_time(page) == pytest.approx(want, abs=0.05)
    page.wait_for_function(f"Number(document.querySelector('#tab').dataset.time) > {want - 0.05}")

    # zoom in keeps the cursor on screen; notes are drawn and some sound under the cursor
    page.click("#tab-zoom-in")
    page.click("#tab-zoom-in")
    page.evaluate("window.scorePlayer.seekTo(45.0)")
    page.wait_for_function("document.querySelector('#tab').dataset.time === '45.000'")
    page.wait_for_timeout(200)
    page.locator("#score-card").screenshot(path=str(tmp_path / "card.png"))
    assert page.errors == []
