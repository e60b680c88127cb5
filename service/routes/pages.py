"""The demo page (``static/index.html``) and its assets."""

from __future__ import annotations

from pathlib import Path

from fastapi import APIRouter
from fastapi.responses import FileResponse

STATIC_DIR = Path(__file__).resolve().parents[2] / "static"

router = APIRouter(tags=["demo"])


@router.get("/", include_in_schema=False)
async def index() -> FileResponse:
    return FileResponse(STATIC_DIR / "index.html", media_type="text/html")


@router.get("/play", include_in_schema=False)
async def play() -> FileResponse:
    """The live-play page: a fretboard, the keyboard and Web MIDI over WS /live."""
    return FileResponse(STATIC_DIR / "live.html", media_type="text/html")
