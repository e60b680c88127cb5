"""POST /render: formats, subtypes, normalisation, headers, diagnostics (in-process app)."""

from __future__ import annotations

import json
import re

import numpy as np
import pytest
from svc_helpers import brief, chord_scene, decode, pluck_scene, same_bytes

import engine

NUMBER = re.compile(r"^-?(\d+(\.\d*)?|\.\d+)([eE][-+]?\d+)?$")


@pytest.mark.parametrize("subtype", ["PCM_16", "PCM_24", "FLOAT"])
def test_wav_subtypes(harness, subtype: str) -> None:
    r = harness.post("/render", json=chord_scene(0.25, output={"subtype": subtype}))
    assert r.status_code == 200, brief(r)
    assert r.headers["content-type"] == "audio/wav"
    x, rate, info = decode(r.content)
    assert (info.format, info.subtype, rate, len(x)) == ("WAV", subtype, 44100, 11025)
    assert np.all(np.isfinite(x)) and np.max(np.abs(x)) > 0.1


@pytest.mark.parametrize("fmt,media,sf_format", [("flac", "audio/flac", "FLAC"),
                                                 ("ogg", "audio/ogg", "OGG")])
def test_flac_and_ogg(harness, fmt: str, media: str, sf_format: str) -> None:
    r = harness.post("/render", json=pluck_scene(0.3, output={"format": fmt}))
    assert r.status_code == 200, brief(r)
    assert r.headers["content-type"] == media
    x, rate, info = decode(r.content)
    assert info.format == sf_format and rate == 44100
    assert np.all(np.isfinite(x)) and np.max(np.abs(x)) > 0.1


@pytest.mark.parametrize("fmt", ["wav", "flac", "ogg"])
def test_stereo(harness, fmt: str) -> None:
    r = harness.post("/render", json=chord_scene(0.25, output={"channels": 2, "format": fmt}))
    assert r.status_code == 200, brief(r)
    x, _, info = decode(r.content)
    assert info.channels == 2 and x.shape[1] == 2 and np.all(np.isfinite(x))
    if fmt != "ogg":
        assert x.shape[0] == 11025


def test_normalized_peak_is_minus_one_dbfs(harness) -> None:
    r = harness.post("/render", json=chord_scene(0.25, output={"subtype": "FLOAT"}))
    x, _, _ = decode(r.content)
    assert np.max(np.abs(x)) == pytest.approx(10 ** (-1 / 20), rel=1e-6)


def test_fixed_gain_follows_force(harness) -> None:
    def peak(force: float) -> float:
        scene = pluck_scene(0.2, output={"normalize": False, "subtype": "FLOAT"})
        scene["events"][0]["force"] = force
        x, _, _ = decode(harness.post("/render", json=scene).content)
        return float(np.max(np.abs(x)))

    soft, loud = peak(0.5), peak(2.0)
    assert loud > 2.0 * soft  # normalisation off: loudness follows the force


@pytest.mark.parametrize("rate", [22050, 48000, 96000])
def test_sample_rates(harness, rate: int) -> None:
    r = harness.post("/render", json=pluck_scene(0.1, sample_rate=rate))
    assert r.status_code == 200, brief(r)
    x, got, _ = decode(r.content)
    assert got == rate and len(x) == round(0.1 * rate)


def test_render_headers(harness) -> None:
    r = harness.post("/render", json=pluck_scene(0.2))
    seconds = float(r.headers["x-render-seconds"])
    assert 0 < seconds < 10
    assert float(r.headers["x-realtime-factor"]) == pytest.approx(0.2 / seconds, rel=0.02)
    assert "x-energy-error" not in r.headers  # only with diagnostics
    firm = harness.post("/render", json={"duration": 0.2, "events": [
        {"type": "tap", "time": 0.0, "string": 3, "fret": 7, "force": 3.0}]})
    assert "x-render-warnings" not in firm.headers  # only when a finger presses too lightly


def light_tap_scene() -> dict:
    """API.md's tap: 0.9 N on string 3 at fret 7, where the string rests on the fret from 1.7 N."""
    return {"duration": 0.3, "events": [
        {"type": "tap", "time": 0.0, "string": 3, "fret": 7, "force": 0.9}]}


@pytest.mark.parametrize("path", ["/render", "/render/stream"])
def test_warnings_header_names_a_finger_too_light_to_seat_its_string(harness, path: str) -> None:
    r = harness.post(path, json=light_tap_scene())
    assert r.status_code == 200, brief(r)
    warnings = json.loads(r.headers["x-render-warnings"])
    assert warnings == engine.scene_warnings(engine.parse_scene(light_tap_scene()))
    assert len(warnings) == 1 and warnings[0].startswith("string 3: the tap at 0 s presses 0.9 N")


def test_diagnostics_energy_error_header(harness) -> None:
    r = harness.post("/render", json=chord_scene(0.2, diagnostics=True))
    assert r.status_code == 200, brief(r)
    value = r.headers["x-energy-error"]
    assert NUMBER.match(value), value  # a plain decimal or exponent number
    assert 0.0 <= float(value) < 1e-6  # energy is conserved to rounding (paper sec. 6.1)


def test_same_scene_same_bytes(harness) -> None:
    scene = chord_scene(0.2)
    first, second = (harness.post("/render", json=scene).content for _ in range(2))
    assert same_bytes(first, second)


def test_silent_scene_is_valid_audio(harness) -> None:
    r = harness.post("/render", json={"duration": 0.1})
    x, _, _ = decode(r.content)
    assert len(x) == 4410 and not np.any(x)


def test_warnings_header_keeps_the_first_ten(harness) -> None:
    """Up to 500 events could each warn: the header carries ten and counts the rest."""
    taps = [{"type": "tap", "time": 0.01 * i, "string": 3, "fret": 7, "force": 0.9}
            for i in range(15)]
    r = harness.post("/render", json={"duration": 0.2, "events": taps})
    assert r.status_code == 200, brief(r)
    warnings = json.loads(r.headers["x-render-warnings"])
    assert len(warnings) == 11 and warnings[-1] == "and 5 more warnings like these"
    assert all(w.startswith("string 3: the tap at") for w in warnings[:10])


