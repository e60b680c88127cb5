"""A waveguide scene gives the same samples however it is cut into blocks (the kernel's period and
reach schedules carry from one call to the next and restart on the global grid of
``BLOCK_MULTIPLE`` samples and where the stop changes): so /render/stream equals /render for
waveguide tracks too, and a live session its render (tests/engine/test_live.py)."""

from __future__ import annotations

import numpy as np
import pytest

import engine
from engine.waveguide.voice import BLOCK_MULTIPLE

SCENES = {
    "damped open string": [
        {"type": "pluck", "time": 0.0, "string": 1, "force": 2.0},
        {"type": "damp", "time": 0.1, "string": 1}],
    "fretted, released, muted": [
        {"type": "fret", "time": 0.0, "string": 3, "fret": 5, "release": 0.3},
        {"type": "pluck", "time": 0.01, "string": 3},
        {"type": "mute", "time": 0.3, "string": 3, "amount": 1.0},
        {"type": "strum", "time": 0.5, "spread": 0.02}],
}


@pytest.mark.parametrize("name", SCENES)
@pytest.mark.parametrize("block", [BLOCK_MULTIPLE, 3 * BLOCK_MULTIPLE, 4096, 1000, 333])
@pytest.mark.parametrize("diagnostics", [False, True])
def test_blocks_equal_the_whole_render(name, block, diagnostics):
    """With diagnostics the decay skip is off: the pieces alone must not depend on the blocks."""
    scene = {"duration": 1.5, "model": "waveguide", "output": {"normalize": False},
             "diagnostics": diagnostics, "events": SCENES[name]}
    whole = engine.render(scene, diagnostics=False) if not diagnostics else \
        engine.render(scene).audio
    parts = np.concatenate([b for b in engine.blocks(scene, block_frames=block)])
    assert np.array_equal(parts, whole)

