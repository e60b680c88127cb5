"""The demo page in a real browser: Debian's chromium driven by Playwright against uvicorn.

Skipped (with the reason) where chromium or the playwright package is missing; never downloads a
browser of its own.
"""

from __future__ import annotations

import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any, get_args

import pytest
from browser import LIT_PIXELS_JS, demo_page, require_browser
from conftest import ROOT, UvicornServer

import engine
from engine.scene import Event

sync_api = require_browser()


@pytest.fixture(scope="module")
def page(server: UvicornServer) -> Iterator[Any]:
    with demo_page(sync_api, server.url, height=1000) as pg:
        yield pg


def _render_example(page: Any, example: str, duration: float) -> None:
    """Load an example, render it: the audio element gets a playable source of the scene's length
    and the spectrogram is drawn."""
    page.click(f"button[data-example='{example}']")
    page.click("#render")
    page.wait_for_selector("#spectrogram[data-drawn='1']", timeout=60_000)
    page.wait_for_function("document.querySelector('#audio').readyState >= 1", timeout=30_000)
    audio = page.evaluate("""() => { const a = document.querySelector('#audio');
        return {src: a.src, duration: a.duration, error: a.error && a.error.code}; }""")
    assert audio["src"].startswith("blob:") and audio["error"] is None
    assert audio["duration"] == pytest.approx(duration, abs=0.01)
    assert page.evaluate(LIT_PIXELS_JS, "#spectrogram") > 0.2


def test_render_an_example_plays_and_draws(page: Any, tmp_path: Path) -> None:
    _render_example(page, "chord", 2.5)
    assert page.evaluate(LIT_PIXELS_JS, "#waveform") > 0.01
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
    assert page.evaluate(LIT_PIXELS_JS, "#spectrogram") > 0.2
    page.uncheck("#stereo")
    assert page.errors == []


def test_the_model_select_renders_on_the_waveguide(page: Any) -> None:
    """Model "waveguide" goes into the scene sent (and greys out the quality, which it has no
    use for); the render plays; an example brings its own model back (fdtd when it names none)."""
    page.click("button[data-example='chord']")
    page.select_option("#model", "waveguide")
    assert page.evaluate("buildScene().model") == "waveguide"
    assert page.is_disabled("#quality")
    with page.expect_request("**/render") as req:
        page.click("#render")
    assert json.loads(req.value.post_data)["model"] == "waveguide"
    page.wait_for_selector("#spectrogram[data-drawn='1']", timeout=60_000)
    assert "Rendered" in page.inner_text("#status")
    page.click("button[data-example='chord']")
    assert page.input_value("#model") == "fdtd" and not page.is_disabled("#quality")
    assert page.errors == []


def _expect_field_error(page: Any, field: str, text: str, err: str | None = None) -> None:
    """After a render, the API's 422 for ``field`` is shown next to its input, and nowhere else."""
    loc = page.locator(err or f".err[data-for='{field}']")
    loc.wait_for(state="visible", timeout=30_000)
    assert text in loc.inner_text()
    assert "invalid" in page.get_attribute(f"input[data-field='{field}']", "class")
    assert page.inner_text("#general-error") == ""


def test_validation_error_is_shown_next_to_its_field(page: Any) -> None:
    page.click("button[data-example='tap']")
    page.fill("input[data-field='events[1].time']", "99")
    page.click("#render")
    _expect_field_error(page, "events[1].time", "outside")
    assert page.errors == []


# ---- every articulation, preset and example ------------------------------------------------
EXAMPLES = json.loads((ROOT / "static" / "examples.json").read_text())["examples"]
# The engine's event models by their `type`: the fields each one takes.
MODELS = {m.model_fields["type"].default: m for m in get_args(get_args(Event)[0])}


def row_fields(page: Any, row: int) -> set[str]:
    """The fields the editor shows in event row ``row`` (without its type selector)."""
    prefix = f"events[{row}]."
    names = page.eval_on_selector_all(
        f"#events tbody tr[data-index='{row}'] [data-field]", "els => els.map(e => e.dataset.field)")
    return {n.removeprefix(prefix) for n in names} - {"type"}


def test_every_example_has_a_button_and_loads_into_the_form_exactly(page: Any) -> None:
    buttons = page.eval_on_selector_all("button[data-example]", "bs => bs.map(b => b.dataset.example)")
    assert buttons == [ex["id"] for ex in EXAMPLES]
    for ex in EXAMPLES:
        page.click(f"button[data-example='{ex['id']}']")
        # What Render would send is the example itself (up to the API's defaults).
        sent = engine.parse_scene(page.evaluate("buildScene()"))
        assert sent == engine.parse_scene(ex["scene"]), ex["id"]
        assert page.inner_text("#example-info") == ex["description"]
    assert page.errors == []


def test_event_editor_shows_the_fields_of_each_type(page: Any) -> None:
    page.click("button[data-example='strum']")
    page.click("#clear")
    page.select_option("#add-type", "pluck")
    page.click("#add")
    select = "select[data-field='events[0].type']"
    assert page.eval_on_selector_all(f"{select} option", "os => os.map(o => o.value)") \
        == list(MODELS)
    for kind, model in MODELS.items():
        page.select_option(select, kind)
        assert row_fields(page, 0) == set(model.model_fields) - {"type"}, kind
    page.select_option(select, "slide")  # e.g. a slide: from/to fret and glide time, no fret
    assert page.is_visible("input[data-field='events[0].from_fret']")
    assert page.is_visible("input[data-field='events[0].duration']")
    assert page.locator("[data-field='events[0].fret']").count() == 0
    page.select_option("#add-type", "mute")  # a new mute rests on all strings
    page.click("#add")
    assert row_fields(page, 1) == {"time", "string", "position", "amount", "release"}
    assert page.input_value("select[data-field='events[1].string']") == ""
    assert "all" in page.inner_text("select[data-field='events[1].string']")
    assert page.errors == []


def test_string_selector_follows_the_presets_string_count(page: Any) -> None:
    page.click("button[data-example='slap-bass']")
    options = page.eval_on_selector_all("select[data-field='events[1].string'] option",
                                        "os => os.map(o => o.textContent)")
    assert options == ["1 G2", "2 D2", "3 A1", "4 E1"]
    page.select_option("#preset", "electric")
    assert page.locator("select[data-field='events[1].string'] option").count() == 6


@pytest.mark.parametrize("example,channels", [("bend", "mono"), ("slap-bass", "mono"),
                                              ("strum-event", "stereo")])
def test_render_articulation_and_instrument_examples(page: Any, example: str,
                                                     channels: str) -> None:
    _render_example(page, example,
                    next(ex["scene"]["duration"] for ex in EXAMPLES if ex["id"] == example))
    assert channels in page.inner_text("#stat-audio")
    assert page.inner_text("#general-error") == ""
    assert page.errors == []


def test_errors_of_articulation_fields_are_shown_next_to_them(page: Any) -> None:
    page.click("button[data-example='bend']")
    page.fill("input[data-field='events[2].semitones']", "5")
    page.click("#add-pickup")
    page.fill("input[data-field='output.pickups[0].position']", "1.5")
    page.click("#render")
    _expect_field_error(page, "events[2].semitones", "less than or equal to 3")
    assert "less than 0.98" in page.inner_text(".err[data-for='output.pickups[0].position']")

    # A strum's string the preset lacks: the engine names it `events[i].strings[j]`.
    page.click("button[data-example='strum-event']")
    page.fill("input[data-field='events[4].strings']", "9 3")
    page.click("#render")
    _expect_field_error(page, "events[4].strings", "outside 1..6",
                        "#events tr[data-index='4'] .err[data-for~='events[4].strings']")
    assert page.errors == []


def test_a_finger_too_light_to_seat_its_string_is_pointed_out(page: Any) -> None:
    """The render's X-Render-Warnings are listed under the form, and cleared by the next render."""
    page.click("button[data-example='tap']")
    page.fill("input[data-field='events[0].force']", "0.9")
    page.click("#render")
    page.wait_for_selector("#warnings:not([hidden])", timeout=60_000)
    items = page.eval_on_selector_all("#warnings li", "els => els.map(e => e.textContent)")
    assert len(items) == 1 and items[0].startswith("string 3: the tap at 0 s presses 0.9 N")
    page.fill("input[data-field='events[0].force']", "3")
    page.click("#render")
    page.wait_for_function("document.querySelector('#status').textContent.startsWith('Rendered')",
                           timeout=60_000)
    assert page.is_hidden("#warnings")
    assert page.errors == []


def test_a_scene_past_the_render_limit_is_rendered_as_a_job(page: Any, tmp_path: Path) -> None:
    """With /render limited to 1 s, the 2.5 s chord example goes to POST /jobs: the page shows
    the job's progress (static/jobs.js), then plays and draws the result."""
    s = UvicornServer(tmp_path, {"GUITAR_WORKERS": "2", "GUITAR_MAX_DURATION_S": "1",
                                 "GUITAR_DATA_DIR": str(tmp_path / "data")}).start()
    try:
        # a page of the module's browser (a second Playwright would run inside the first's loop)
        pg = page.context.browser.new_page(viewport={"width": 1400, "height": 1000})
        errors: list[str] = []
        pg.on("pageerror", lambda e: errors.append(str(e)))
        jobs: list[str] = []
        pg.on("request", lambda r: jobs.append(r.url) if "/jobs" in r.url else None)
        pg.goto(s.url + "/")
        pg.wait_for_selector("body[data-ready='1']", timeout=30_000)
        pg.click("button[data-example='chord']")
        pg.click("#render")
        pg.wait_for_selector("#job-progress:not([hidden])", timeout=30_000)
        try:
            pg.wait_for_selector("#spectrogram[data-drawn='1']", timeout=120_000)
        except sync_api.TimeoutError:
            raise AssertionError((pg.inner_text("#status"), pg.inner_text("#general-error"),
                                  errors)) from None
        assert "as a job" in pg.inner_text("#status")
        assert pg.is_hidden("#job-progress")
        duration = pg.evaluate("document.querySelector('#audio').duration")
        assert duration == pytest.approx(2.5, abs=0.01)
        assert any(u.endswith("/audio") for u in jobs), jobs
        assert errors == []
        pg.close()
    finally:
        s.stop()
