"""Every page works with no network: the API docs (Swagger UI at /docs, ReDoc at /redoc) and the
demo pages load only from this server. In Debian's chromium (Playwright) with every request to
another host aborted and recorded.

Skipped (with the reason) where chromium or the playwright package is missing.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any
from urllib.parse import urlsplit

import httpx
import pytest
from browser import ARGS, CHROMIUM, require_browser
from conftest import UvicornServer

sync_api = require_browser()


@pytest.fixture(scope="module")
def offline(server: UvicornServer) -> Iterator[tuple[Any, list[str]]]:
    """A browser context whose requests to any host but 127.0.0.1 are aborted (and listed)."""
    left: list[str] = []

    def only_local(route: Any) -> None:
        if urlsplit(route.request.url).hostname == "127.0.0.1":
            route.continue_()
        else:
            left.append(route.request.url)
            route.abort("internetdisconnected")

    with sync_api.sync_playwright() as p:
        browser = p.chromium.launch(executable_path=CHROMIUM, args=ARGS)
        context = browser.new_context(viewport={"width": 1300, "height": 900})
        context.route("**/*", only_local)
        yield context, left
        browser.close()


def _open(context: Any, url: str) -> tuple[Any, list[str]]:
    page = context.new_page()
    errors: list[str] = []
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.goto(url)
    return page, errors


def test_swagger_ui_renders_every_operation_offline(server: UvicornServer, offline: Any) -> None:
    context, left = offline
    spec = httpx.get(server.url + "/openapi.json").json()
    operations = sum(len(ops) for ops in spec["paths"].values())
    page, errors = _open(context, server.url + "/docs")
    page.wait_for_selector(".opblock", timeout=30_000)
    assert page.locator(".opblock").count() == operations
    assert page.locator(".opblock-summary-path[data-path='/render/score']").count() == 1
    page.close()
    assert left == [] and errors == []


def test_redoc_renders_offline(server: UvicornServer, offline: Any) -> None:
    context, left = offline
    page, errors = _open(context, server.url + "/redoc")
    page.wait_for_selector("[data-section-id^='operation/']", state="attached", timeout=60_000)
    assert "POST /render" in page.inner_text("body").replace("\n", " ") or \
        page.locator("[data-section-id^='operation/']").count() > 10
    page.close()
    assert left == [] and errors == []


@pytest.mark.parametrize("path", ["/", "/play"])
def test_demo_pages_ask_nothing_of_other_hosts(server: UvicornServer, offline: Any,
                                               path: str) -> None:
    context, left = offline
    page, errors = _open(context, server.url + path)
    page.wait_for_load_state("networkidle", timeout=30_000)
    page.close()
    assert left == [] and errors == []
