"""The live-play page (/play) in Debian's chromium against uvicorn: it connects to WS /live, plays
notes from the computer keyboard and from a simulated Web MIDI input (a fake
``navigator.requestMIDIAccess`` injected before the page's scripts), audio blocks arrive at its
AudioWorklet, and the latency figure is shown.

Skipped (with the reason) where chromium or the playwright package is missing."""

from __future__ import annotations

import re
import shutil
from collections.abc import Iterator
from typing import Any

import httpx
import pytest
from conftest import UvicornServer

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
ARGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-background-networking",
        "--disable-component-update", "--disable-sync", "--no-first-run",
        "--use-fake-ui-for-media-stream", "--use-fake-device-for-media-stream",
        "--autoplay-policy=no-user-gesture-required"]

if CHROMIUM is None:
    pytest.skip("chromium is not installed (apt-get install chromium)", allow_module_level=True)
sync_api = pytest.importorskip("playwright.sync_api",
                               reason="playwright is not installed (pip install playwright)")

# A MIDI input the test plays through: window.__midi.send([status, data1, data2]).
FAKE_MIDI = """
(() => {
  const input = { name: "Test keyboard", onmidimessage: null };
  window.__midi = { send: (bytes) => input.onmidimessage &&
    input.onmidimessage({ data: new Uint8Array(bytes) }) };
  navigator.requestMIDIAccess = async () => ({
    inputs: new Map([["test", input]]), outputs: new Map(), onstatechange: null });
})();
"""


@pytest.fixture(scope="module")
def live_server(tmp_path_factory: pytest.TempPathFactory) -> Iterator[UvicornServer]:
    # the live worker starts with the first session (the page's Connect), which waits for it
    s = UvicornServer(tmp_path_factory.mktemp("live-browser"), {
        "GUITAR_WORKERS": "1", "GUITAR_LIVE_WORKERS": "1"}).start()
    assert httpx.get(s.url + "/live/status").json()["started"] is False
    yield s
    s.stop()


@pytest.fixture(scope="module")
def page(live_server: UvicornServer) -> Iterator[Any]:
    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        pg = browser.new_page(viewport={"width": 1300, "height": 900})
        pg.errors = []  # type: ignore[attr-defined]
        pg.on("pageerror", lambda e: pg.errors.append(str(e)))  # type: ignore[attr-defined]
        pg.add_init_script(FAKE_MIDI)
        pg.goto(live_server.url + "/play")
        pg.wait_for_selector("body[data-ready='1']", timeout=30_000)
        yield pg
        browser.close()


def _blocks(page: Any) -> int:
    return int(page.inner_text("#live-blocks"))


def test_play_from_keyboard_and_midi(page: Any) -> None:
    assert page.inner_text("#live-midi") == "Use MIDI"  # nothing asked of the browser unasked
    page.click("#live-midi-enable")
    page.wait_for_function("document.querySelector('#live-midi').textContent === 'Test keyboard'")
    frets = next(p["frets"] for p in httpx.get(page.url.removesuffix("/play") + "/presets").json()[
        "presets"] if p["name"] == "steel-acoustic")
    assert frets > 12 and page.locator("#fretboard .cell").count() == 6 * (frets + 1)
    page.click("#live-connect")
    page.wait_for_selector("body[data-live='1']", timeout=180_000)
    assert "playing steel-acoustic" in page.inner_text("#live-status")
    page.wait_for_function("Number(document.querySelector('#live-blocks').textContent) > 20",
                           timeout=20_000)
    # the keyboard: fret 3, then strings 5 and 4; a hammer-on; a bend held and let go
    page.keyboard.press("3")
    assert page.inner_text("#live-fret") == "3"
    page.keyboard.press("s")
    page.keyboard.press("d")
    page.keyboard.press("Shift+D")
    page.keyboard.down("b")
    page.wait_for_timeout(150)
    page.keyboard.up("b")
    page.keyboard.down("m")  # a palm on every string, lifted
    page.wait_for_timeout(100)
    page.keyboard.up("m")
    assert page.get_attribute("#fretboard .cell[data-string='5'][data-fret='3']", "class").count("held")
    # the fretboard: a click plucks string 1 at fret 5
    page.click("#fretboard .cell[data-string='1'][data-fret='5']")
    # MIDI: E4 and G3 at two velocities, the wheel up and back, a note off
    for msg in ([0x90, 64, 100], [0x90, 55, 40], [0xE0, 0, 96], [0xE0, 0, 64], [0x80, 64, 0]):
        page.evaluate("(m) => window.__midi.send(m)", msg)
        page.wait_for_timeout(60)
    assert page.inner_text("#live-midi") == "2 notes"
    page.wait_for_function("document.querySelector('#live-latency').dataset.ms !== undefined",
                           timeout=10_000)
    latency = page.inner_text("#live-latency")
    assert re.match(r"\d+(\.\d)? ms median \(\d+ events\)", latency), latency
    ms = float(page.get_attribute("#live-latency", "data-ms"))
    assert 0.0 < ms < 1000.0
    before = _blocks(page)
    page.wait_for_timeout(500)
    assert _blocks(page) > before  # the stream goes on
    assert page.inner_text("#live-log") == ""  # nothing was refused
    # the underrun count is shown (its value depends on the machine's load, not on the page)
    assert re.fullmatch(r"\d+", page.inner_text("#live-underruns"))
    assert page.errors == []
    page.click("#live-connect")  # disconnect
    page.wait_for_function("document.querySelector('#live-status').textContent.startsWith('closed')")


def test_play_the_waveguide_model(page: Any) -> None:
    """The page's model selector opens a waveguide session, which plays the same controls."""
    assert page.is_enabled("#live-quality")
    page.select_option("#live-model", "waveguide")
    assert page.is_disabled("#live-quality")  # quality does nothing on the waveguide model
    page.click("#live-connect")
    page.wait_for_function("document.querySelector('#live-status').textContent"
                           ".startsWith('playing steel-acoustic (waveguide)')", timeout=60_000)
    page.wait_for_function("Number(document.querySelector('#live-blocks').textContent) > 20",
                           timeout=20_000)
    page.keyboard.press("5")
    page.keyboard.press("a")
    page.click("#fretboard .cell[data-string='2'][data-fret='3']")
    page.evaluate("(m) => window.__midi.send(m)", [0x90, 60, 90])
    before = _blocks(page)
    page.wait_for_timeout(500)
    assert _blocks(page) > before
    assert page.inner_text("#live-log") == ""  # nothing was refused
    assert page.errors == []
    page.click("#live-connect")
    page.wait_for_function("document.querySelector('#live-status').textContent.startsWith('closed')")
    page.select_option("#live-model", "fdtd")
    assert page.is_enabled("#live-quality")
