"""Scenes and small checks shared by the service tests (short scenes: this runs on two cores)."""

from __future__ import annotations

import io
from typing import Any

import numpy as np
import soundfile as sf


def pluck_scene(duration: float = 0.2, string: int = 1, **extra: Any) -> dict[str, Any]:
    return {"duration": duration,
            "events": [{"type": "pluck", "time": 0.0, "string": string, "force": 2.0}], **extra}


def chord_scene(duration: float = 0.3, **extra: Any) -> dict[str, Any]:
    """Fretted C major shape, strummed: every event type the engine has, on several strings."""
    frets = {5: 3, 4: 2, 2: 1}
    events: list[dict[str, Any]] = [
        {"type": "fret", "time": 0.0, "string": s, "fret": f, "force": 2.0}
        for s, f in frets.items()
    ]
    events += [{"type": "pluck", "time": 0.005 + 0.01 * i, "string": s, "force": 2.0}
               for i, s in enumerate((5, 4, 3, 2, 1))]
    events.append({"type": "tap", "time": duration / 2, "string": 3, "fret": 7, "force": 0.9})
    return {"duration": duration, "events": events, **extra}


def heavy_scene(duration: float) -> dict[str, Any]:
    """Expensive per second of audio: six strings held at the 5th fret (a finger on a string makes
    the engine oversample it), quality 'high', 96 kHz.  About 0.3 s of work per second of audio on
    the 2-core machine of 2026-11 (1 s when this was written): the tests that need a render to
    outlast a time limit, or to take long enough to tell streaming from buffering, ask for 6 s."""
    frets = [{"type": "fret", "time": 0.0, "string": s, "fret": 5, "force": 2.0}
             for s in range(1, 7)]
    plucks = [{"type": "pluck", "time": 0.01 * i, "string": s, "force": 2.0}
              for i, s in enumerate(range(6, 0, -1))]
    return {"duration": duration, "sample_rate": 96000, "quality": "high",
            "events": frets + plucks}


def same_bytes(a: bytes, b: bytes) -> bool:
    """Equality without pytest printing kilobytes of audio when it fails."""
    return len(a) == len(b) and a == b


def decode(data: bytes) -> tuple[np.ndarray, int, Any]:
    info = sf.info(io.BytesIO(data))
    x, rate = sf.read(io.BytesIO(data), dtype="float64")
    return x, rate, info


def fields(response: Any) -> list[str]:
    return [d["field"] for d in response.json()["detail"]]


def brief(r: Any) -> str:
    """A failure message for a response: its JSON error, or a summary of its audio."""
    if r.headers.get("content-type", "").startswith("application/json"):
        return f"{r.status_code} {r.text[:500]}"
    return f"{r.status_code} {r.headers.get('content-type')} {len(r.content)} bytes"

