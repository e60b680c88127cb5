"""The demo pages (``static/index.html``, ``static/live.html``) and the API docs.

``/docs`` (Swagger UI) and ``/redoc`` load their scripts and styles from this server, never from a
CDN: the assets are the ones the ``fastapi-offline`` package ships, mounted at ``DOCS_ASSETS``, so
the docs work on a machine with no network.
"""

from __future__ import annotations

from functools import cache
from pathlib import Path

import fastapi_offline
from fastapi import APIRouter, Request
from fastapi.openapi.docs import (
    get_redoc_html,
    get_swagger_ui_html,
    get_swagger_ui_oauth2_redirect_html,
)
from fastapi.responses import FileResponse, HTMLResponse, Response
from fastapi.staticfiles import StaticFiles

STATIC_DIR = Path(__file__).resolve().parents[2] / "static"
DOCS_ASSETS = "/docs-assets"
_DOCS_DIR = Path(fastapi_offline.__file__).resolve().parent / "static"

router = APIRouter(tags=["demo"])


@router.get("/", include_in_schema=False)
async def index() -> FileResponse:
    return FileResponse(STATIC_DIR / "index.html", media_type="text/html")


@router.get("/play", include_in_schema=False)
async def play() -> FileResponse:
    """The live-play page: a fretboard, the keyboard and Web MIDI over WS /live."""
    return FileResponse(STATIC_DIR / "live.html", media_type="text/html")


def docs_assets() -> StaticFiles:
    """The Swagger UI and ReDoc files, to mount at ``DOCS_ASSETS``."""
    return StaticFiles(directory=_DOCS_DIR)


docs_router = APIRouter(include_in_schema=False)


def _root(request: Request) -> str:
    return request.scope.get("root_path", "")


@docs_router.get("/docs")
async def swagger_ui(request: Request) -> HTMLResponse:
    app, root = request.app, _root(request)
    return get_swagger_ui_html(
        openapi_url=f"{root}{app.openapi_url}", title=f"{app.title} — API docs",
        oauth2_redirect_url=f"{root}{app.swagger_ui_oauth2_redirect_url}",
        swagger_js_url=f"{root}{DOCS_ASSETS}/swagger-ui-bundle.js",
        swagger_css_url=f"{root}{DOCS_ASSETS}/swagger-ui.css",
        swagger_favicon_url=f"{root}{DOCS_ASSETS}/favicon.png",
        # no call to validator.swagger.io for the badge
        swagger_ui_parameters={"validatorUrl": None, **(app.swagger_ui_parameters or {})})


@docs_router.get("/docs/oauth2-redirect")
async def swagger_ui_redirect() -> HTMLResponse:
    return get_swagger_ui_oauth2_redirect_html()


# ReDoc's one hard-wired outside address: the Redocly logo in its sidebar, fetched from a CDN.  The
# copy served here points it at an empty local image instead, so that nothing leaves the machine.
_REDOC_LOGO = b"https://cdn.redoc.ly/redoc/logo-mini.svg"
_EMPTY_SVG = b"data:image/svg+xml,%3Csvg xmlns='http://www.w3.org/2000/svg' width='0' height='0'/%3E"


@cache
def _redoc_js() -> bytes:
    return (_DOCS_DIR / "redoc.standalone.js").read_bytes().replace(_REDOC_LOGO, _EMPTY_SVG)


@docs_router.get("/docs/redoc.js")
async def redoc_js() -> Response:
    return Response(_redoc_js(), media_type="text/javascript",
                    headers={"Cache-Control": "public, max-age=3600"})


@docs_router.get("/redoc")
async def redoc(request: Request) -> HTMLResponse:
    app, root = request.app, _root(request)
    return get_redoc_html(
        openapi_url=f"{root}{app.openapi_url}", title=f"{app.title} — ReDoc",
        redoc_js_url=f"{root}/docs/redoc.js",
        redoc_favicon_url=f"{root}{DOCS_ASSETS}/favicon.png", with_google_fonts=False)
