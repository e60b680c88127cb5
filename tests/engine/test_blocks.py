"""Block rendering carries the state: block boundaries do not change a single sample."""

import numpy as np
import pytest

import engine
from engine.guitar import prepare
from engine.scene import Scene

from .conftest import fret, pluck, scene, tap

SCENE = scene([fret(2, 5), pluck(2, time=0.01, force=8.0), tap(3, 7, time=0.05),
               pluck(6, time=0.02, force=4.0), fret(2, 0, time=0.12)], duration=0.2)


def _blocks(block):
    eng = prepare(Scene.model_validate(SCENE))
    return np.concatenate(list(eng.blocks(block)))


@pytest.mark.parametrize("block", [1, 37, 1000, 4096])
def test_blocks_equal_one_shot(block):
    one = _blocks(10**9)
    assert np.array_equal(one, _blocks(block))


@pytest.mark.parametrize("output", [
    {"normalize": False},
    {"normalize": False, "body": "acoustic", "channels": 2},
    {"normalize": False, "pickups": [{"position": 0.9}, {"position": 0.75, "gain": 0.5}]},
])
def test_stream_blocks_equal_render_with_fixed_gain(output):
    """engine.blocks (what a stream sends) = render with normalize false, body and stereo too."""
    sc = {**SCENE, "output": output}
    whole = engine.render(sc)
    streamed = np.concatenate(list(engine.blocks(sc, block_frames=777)))
    assert np.array_equal(whole, streamed)
