"""What the demo-page tests share: Debian's chromium driven by PyPI's playwright (never
``playwright install``), a page opened on a running server, and a measure of what a canvas drew.

A test module calls ``sync_api = require_browser()`` at import: where chromium or the playwright
package is missing, the module is skipped with the reason.
"""

from __future__ import annotations

import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import pytest

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
        "--disable-component-update", "--disable-sync", "--no-first-run"]
AUDIO_ARGS = ["--autoplay-policy=no-user-gesture-required"]

# Share of a canvas's pixels brighter than its darkest colour.
LIT_PIXELS_JS = """(sel) => {
  const c = document.querySelector(sel);
  const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
  let min = 1e9;
  for (let i = 0; i < d.length; i += 4) min = Math.min(min, d[i] + d[i + 1] + d[i + 2]);
  let lit = 0;
  for (let i = 0; i < d.length; i += 4) if (d[i] + d[i + 1] + d[i + 2] > min + 30) lit++;
  return lit / (d.length / 4);
}"""


def require_browser() -> Any:
    """playwright's sync API, or a module-level skip that says what is missing."""
    if CHROMIUM is None:
        pytest.skip("chromium is not installed (apt-get install chromium)",
                    allow_module_level=True)
    return pytest.importorskip("playwright.sync_api",
                               reason="playwright is not installed (pip install playwright)")


@contextmanager
def demo_page(sync_api: Any, url: str, height: int = 1000,
              extra_args: tuple[str, ...] = ()) -> Iterator[Any]:
    """The demo page of the server at ``url``, loaded and ready; ``page.errors`` collects the
    page's uncaught errors."""
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=[*ARGS, *extra_args])
        pg = browser.new_page(viewport={"width": 1400, "height": height})
        pg.errors = []
        pg.on("pageerror", lambda e: pg.errors.append(str(e)))
        pg.goto(url + "/")
        pg.wait_for_selector("body[data-ready='1']", timeout=30_000)
        yield pg
        browser.close()
