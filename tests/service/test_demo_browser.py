"""The demo page in a real browser: Debian's chromium driven by Playwright against uvicorn.

Skipped (with the reason) where chromium or the playwright package is missing; never downloads a
browser of its own.
"""

from __future__ import annotations

import shutil
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from conftest import UvicornServer

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
        "--disable-component-update", "--disable-sync", "--no-first-run"]

if CHROMIUM is None:
    pytest.skip("chromium is not installed (apt-get install chromium)", allow_module_level=True)
sync_api = pytest.importorskip("playwright.sync_api",
                               reason="playwright is not installed (pip install playwright)")

# Share of canvas pixels that differ from the darkest colour of the image.
_LIT_PIXELS_JS = """(sel) => {
  const c = document.querySelector(sel);
  const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
  let min = 1e9;
  for (let i = 0; i < d.length; i += 4) min = Math.min(min, d[i] + d[i + 1] + d[i + 2]);
  let lit = 0;
  for (let i = 0; i < d.length; i += 4) if (d[i] + d[i + 1] + d[i + 2] > min + 30) lit++;
  return lit / (d.length / 4);
}"""


@pytest.fixture(scope="module")
def page(server: UvicornServer) -> Iterator[Any]:
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        pg = browser.new_page(viewport={"width": 1400, "height": 1000})
        pg.errors = []  # type: ignore[attr-defined]
        pg.on("pageerror", lambda e: pg.errors.append(str(e)))  # type: ignore[attr-defined]
        pg.goto(server.url + "/")
        pg.wait_for_selector("body[data-ready='1']", timeout=30_000)
        yield pg
        browser.close()


def test_render_an_example_plays_and_draws(page: Any, tmp_path: Path) -> None:
    page.click("button[data-example='chord']")
    page.click("#render")
    page.wait_for_selector("#spectrogram[data-drawn='1']", timeout=60_000)
    page.wait_for_function("document.querySelector('#audio').readyState >= 1", timeout=30_000)
    audio = page.evaluate("""() => { const a = document.querySelector('#audio');
        return {src: a.src, duration: a.duration, error: a.error && a.error.code}; }""")
    assert audio["src"].startswith("blob:") and audio["error"] is None
    assert audio["duration"] == pytest.approx(2.5, abs=0.01)
    assert page.evaluate(_LIT_PIXELS_JS, "#spectrogram") > 0.2
    assert page.evaluate(_LIT_PIXELS_JS, "#waveform") > 0.01
    assert "Rendered" in page.inner_text("#status")
    assert "real time" in page.inner_text("#stat-rtf")
    assert page.get_attribute("#download", "download") == "guitar.wav"
    page.screenshot(path=str(tmp_path / "demo.png"), full_page=True)
    assert page.errors == []


def test_stereo_render(page: Any) -> None:
    page.click("button[data-example='strum']")
    page.check("#stereo")
    page.click("#render")
    page.wait_for_selector("#spectrogram[data-drawn='1']", timeout=60_000)
    assert "stereo" in page.inner_text("#stat-audio")
    assert page.evaluate(_LIT_PIXELS_JS, "#spectrogram") > 0.2
    page.uncheck("#stereo")
    assert page.errors == []


def test_validation_error_is_shown_next_to_its_field(page: Any) -> None:
    page.click("button[data-example='tap']")
    page.fill("input[data-field='events[1].time']", "99")
    page.click("#render")
    err = page.locator(".err[data-for='events[1].time']")
    err.wait_for(state="visible", timeout=30_000)
    assert "outside" in err.inner_text()
    assert "invalid" in page.get_attribute("input[data-field='events[1].time']", "class")
    assert page.inner_text("#general-error") == ""
    assert page.errors == []
