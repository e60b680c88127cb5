"""Worked request examples for the OpenAPI document: one per event type, plus output options.

Event types the engine adds later (slide, hammer_on, ...) get an example automatically from the
``examples`` their engine model declares, so the docs follow the engine without a service change.
"""

from __future__ import annotations

from typing import Any

import engine

_WORKED: dict[str, dict[str, Any]] = {
    "pluck": {
        "summary": "pluck: an open-string strum",
        "description": "Six plucks from string 6 to string 1, 15 ms apart, near the bridge.",
        "value": {
            "duration": 1.5,
            "guitar": {"preset": "steel-acoustic"},
            "events": [
                {"type": "pluck", "time": 0.015 * i, "string": 6 - i, "position": 0.85,
                 "force": 1.5}
                for i in range(6)
            ],
        },
    },
    "fret": {
        "summary": "fret: a fretted melody",
        "description": "A finger moves along string 2 (frets 1, 3, 5) and each note is plucked.",
        "value": {
            "duration": 1.5,
            "events": [
                {"type": "fret", "time": 0.0, "string": 2, "fret": 1, "force": 3.0},
                {"type": "pluck", "time": 0.02, "string": 2, "force": 2.0},
                {"type": "fret", "time": 0.5, "string": 2, "fret": 3, "force": 3.0},
                {"type": "pluck", "time": 0.52, "string": 2, "force": 2.0},
                {"type": "fret", "time": 1.0, "string": 2, "fret": 5, "force": 3.0,
                 "release": 1.4},
                {"type": "pluck", "time": 1.02, "string": 2, "force": 2.0},
            ],
        },
    },
    "tap": {
        "summary": "tap: a note struck by a finger, no pluck",
        "description": "Two taps on string 3 (paper Fig. 3c); the second lifts at 1.2 s.",
        "value": {
            "duration": 1.5,
            "guitar": {"preset": "nylon-classical"},
            "events": [
                {"type": "tap", "time": 0.0, "string": 3, "fret": 7, "force": 2.5,
                 "velocity": 1.5},
                {"type": "tap", "time": 0.6, "string": 3, "fret": 9, "force": 2.5,
                 "release": 1.2},
            ],
        },
    },
}

_OPTIONS: dict[str, dict[str, Any]] = {
    "flac-diagnostics": {
        "summary": "FLAC output with diagnostics (X-Energy-Error)",
        "value": {
            "duration": 1.0,
            "sample_rate": 48000,
            "events": [{"type": "pluck", "time": 0.0, "string": 6, "force": 3.0}],
            "output": {"format": "flac"},
            "diagnostics": True,
        },
    },
    "fixed-gain-wav24": {
        "summary": "24-bit WAV at the fixed gain (what /render/stream sends)",
        "value": {
            "duration": 1.0,
            "events": [{"type": "pluck", "time": 0.0, "string": 1, "force": 1.0}],
            "output": {"format": "wav", "subtype": "PCM_24", "normalize": False},
        },
    },
}


def _engine_event_examples() -> dict[str, dict[str, Any]]:
    """Event type -> the example event its engine model declares (from the JSON schema)."""
    schema = engine.Scene.model_json_schema()
    mapping = schema["properties"]["events"]["items"].get("discriminator", {}).get("mapping", {})
    out = {}
    for tag, ref in mapping.items():
        model = schema["$defs"].get(ref.rsplit("/", 1)[-1], {})
        examples = model.get("examples") or []
        if examples:
            out[tag] = examples[0]
    return out


def scene_examples() -> dict[str, dict[str, Any]]:
    examples = {name: ex for name, ex in _WORKED.items()}
    for tag, event in _engine_event_examples().items():
        if tag not in examples:
            event = {**event, "time": 0.0}
            examples[tag] = {
                "summary": f"{tag}: the engine's example event",
                "value": {"duration": 1.0, "events": [event]},
            }
    examples.update(_OPTIONS)
    return examples


def stream_examples() -> dict[str, dict[str, Any]]:
    """The same scenes, as WAV (a stream is always WAV at the fixed gain)."""
    out = {}
    for name, ex in scene_examples().items():
        value = dict(ex["value"])
        if value.get("output", {}).get("format", "wav") != "wav":
            continue
        out[name] = {**ex, "value": value}
    return out
