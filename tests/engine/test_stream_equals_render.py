"""``engine.blocks`` at the service's stream block size, concatenated, equals ``engine.render`` with
``normalize: false``, sample for sample, for any scene (API.md: /render/stream's bytes are those of
/render with ``normalize: false``).

The property is drawn over random scenes at every quality and several sample rates, with forces
from barely touching to firm: the decay skip (a string stops being computed once its motion is
below ``decay_velocity``) must stop a string at the same step whatever the blocks are, which a
fixed example rarely exercises.
"""

from __future__ import annotations

import numpy as np
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

import engine
from service.config import Settings

STREAM_BLOCK = Settings.model_fields["stream_block_frames"].default
RATES = (22050, 44100, 48000, 96000)


@st.composite
def scenes(draw):
    duration = draw(st.floats(0.05, 0.6))
    events = []
    for _ in range(draw(st.integers(1, 4))):
        string = draw(st.integers(1, 6))
        time = draw(st.floats(0.0, duration * 0.6))
        kind = draw(st.sampled_from(["pluck", "tap", "fret", "mute", "harmonic"]))
        if kind == "pluck":
            events.append({"type": "pluck", "time": time, "string": string,
                           "force": 10.0 ** draw(st.floats(-7.0, 0.6))})
        elif kind == "tap":
            events.append({"type": "tap", "time": time, "string": string,
                           "fret": draw(st.integers(1, 12)),
                           "velocity": 10.0 ** draw(st.floats(-7.0, 0.0))})
        elif kind == "fret":
            events.append({"type": "fret", "time": time, "string": string,
                           "fret": draw(st.integers(0, 12))})
        elif kind == "mute":
            events.append({"type": "mute", "time": time, "string": string,
                           "amount": draw(st.floats(0.0, 1.0))})
        else:
            events.append({"type": "harmonic", "time": time, "string": string, "fret": 12,
                           "release": time + 0.01})
    return {
        "duration": duration,
        "sample_rate": draw(st.sampled_from(RATES)),
        "quality": draw(st.sampled_from(["draft", "standard", "high"])),
        "output": {"normalize": False, "channels": draw(st.sampled_from([1, 2])),
                   "pickup_position": draw(st.floats(0.021, 0.97))},
        "events": events,
    }


# Found by a fuzz: the decay skip stopped string 5 at a block boundary, and the boundaries of a
# 2048-frame render and a 4096-frame stream differ.
DECAYED = {"duration": 1.2, "sample_rate": 48000, "quality": "draft",
           "output": {"normalize": False, "pickup_position": 0.7334},
           "events": [{"type": "pluck", "time": 0.15, "string": 5, "force": 1.2e-7},
                      {"type": "tap", "time": 0.044, "string": 2, "fret": 9, "velocity": 4e-5},
                      {"type": "pluck", "time": 0.013, "string": 6, "force": 1.1e-7}]}


@settings(max_examples=30, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(scenes())
@example(DECAYED)
def test_stream_blocks_equal_render(scene):
    whole = engine.render(scene)
    for block in (STREAM_BLOCK, 777):
        streamed = np.concatenate(list(engine.blocks(scene, block_frames=block)))
        assert streamed.shape == whole.shape
        assert np.array_equal(streamed, whole), (
            f"block {block}: first difference at frame "
            f"{int(np.argmax(np.any((streamed != whole).reshape(len(whole), -1), axis=1)))}")
