"""POST /render/stream: a valid WAV whose bytes equal /render's with normalize false."""

from __future__ import annotations

import numpy as np
import pytest
from svc_helpers import chord_scene, decode, fields, pluck_scene, same_bytes

import engine


@pytest.mark.parametrize("subtype", ["PCM_16", "PCM_24", "FLOAT"])
@pytest.mark.parametrize("rate", [44100, 48000])
def test_stream_equals_render_without_normalisation(harness, subtype: str, rate: int) -> None:
    scene = chord_scene(0.3, sample_rate=rate, output={"subtype": subtype, "normalize": False})
    streamed = harness.post("/render/stream", json=scene)
    whole = harness.post("/render", json=scene)
    assert streamed.status_code == 200 and whole.status_code == 200
    assert streamed.headers["content-type"] == "audio/wav"
    assert int(streamed.headers["content-length"]) == len(streamed.content)
    assert same_bytes(streamed.content, whole.content)
    x, got_rate, info = decode(streamed.content)
    assert (info.subtype, got_rate, len(x)) == (subtype, rate, engine.frame_count(scene))
    assert np.max(np.abs(x)) > 0.01


@pytest.mark.parametrize("subtype", ["PCM_16", "FLOAT"])
def test_stereo_stream_equals_render(harness, subtype: str) -> None:
    scene = chord_scene(0.3, output={"channels": 2, "subtype": subtype, "normalize": False})
    streamed = harness.post("/render/stream", json=scene)
    whole = harness.post("/render", json=scene)
    assert streamed.status_code == 200 and whole.status_code == 200
    assert int(streamed.headers["content-length"]) == len(streamed.content)
    assert same_bytes(streamed.content, whole.content)
    x, _, info = decode(streamed.content)
    assert info.channels == 2 and x.shape == (engine.frame_count(scene), 2)
    assert not np.allclose(x[:, 0], x[:, 1])  # panned: the channels differ


def test_stream_spans_many_blocks(harness) -> None:
    # 1.2 s at 44.1 kHz is 13 blocks of 4096 frames: block joins must be seamless.
    scene = pluck_scene(1.2, string=6, output={"normalize": False})
    streamed = harness.post("/render/stream", json=scene)
    assert same_bytes(streamed.content, harness.post("/render", json=scene).content)


def test_stream_ignores_normalize_and_uses_the_fixed_gain(harness) -> None:
    scene = pluck_scene(0.2)
    streamed = harness.post("/render/stream", json=scene)  # normalize defaults to true
    fixed = harness.post("/render", json={**scene, "output": {"normalize": False}})
    assert same_bytes(streamed.content, fixed.content)


def test_stream_header_says_time_to_first_block(harness) -> None:
    r = harness.post("/render/stream", json=pluck_scene(0.2))
    assert 0 < float(r.headers["x-render-seconds"]) < 10


@pytest.mark.parametrize("fmt", ["flac", "ogg"])
def test_stream_refuses_flac_and_ogg(harness, fmt: str) -> None:
    r = harness.post("/render/stream", json=pluck_scene(0.2, output={"format": fmt}))
    assert r.status_code == 422
    assert fields(r) == ["output.format"]
    assert "/render" in r.json()["detail"][0]["msg"]
