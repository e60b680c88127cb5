"""Block rendering carries the state: block boundaries do not change a single sample."""

import numpy as np
import pytest

import engine
from engine.fd.instrument import prepare
from engine.scene import Scene
from engine.testing.scenes import fret, pluck, scene, tap

SCENE = scene([fret(2, 5), pluck(2, time=0.01, force=8.0), tap(3, 7, time=0.05),
               pluck(6, time=0.02, force=4.0), fret(2, 0, time=0.12)], duration=0.2)


ARTICULATIONS = scene([
    fret(3, 5), pluck(3, time=0.005), {"type": "slide", "time": 0.03, "string": 3,
                                       "from_fret": 5, "to_fret": 7, "duration": 0.05},
    {"type": "hammer_on", "time": 0.1, "string": 3, "fret": 9},
    {"type": "pull_off", "time": 0.15, "string": 3, "fret": 9},
    pluck(2, style="pick"), {"type": "bend", "time": 0.02, "string": 2, "semitones": 1.5,
                             "duration": 0.05, "release": 0.12},
    pluck(1, style="pop"), {"type": "vibrato", "time": 0.01, "string": 1, "depth_cents": 40,
                            "rate_hz": 9, "duration": 0.15},
    {"type": "harmonic", "time": 0.0, "string": 4, "fret": 12, "release": 0.05}, pluck(4),
    {"type": "mute", "time": 0.0, "string": 6, "amount": 0.5}, pluck(6, style="slap"),
    {"type": "strum", "time": 0.1, "strings": [5, 4], "direction": "up"},
], duration=0.2)


def _blocks(block, sc=SCENE):
    eng = prepare(Scene.model_validate(sc))
    return np.concatenate(list(eng.blocks(block)))


@pytest.mark.parametrize("block", [1, 37, 1000, 4096])
@pytest.mark.parametrize("sc", [SCENE, ARTICULATIONS], ids=["contacts", "articulations"])
def test_blocks_equal_one_shot(block, sc):
    one = _blocks(10**9, sc)
    assert np.array_equal(one, _blocks(block, sc))


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


def test_silence_is_skipped_by_the_mix_and_a_worker_keeps_only_a_few_lengths_of_it() -> None:
    """A sleeping voice returns ``output.silence(m)``, which the mix skips (the same samples as
    adding it); a process that renders scenes of every length keeps few such arrays."""
    import numpy as np

    from engine import output

    for m in range(1, 200):
        output.silence(m)
    assert len(output._SILENCE) <= output._SILENCE_LENGTHS
    z = output.silence(64)
    assert not z.flags.writeable and not z.any()
    mono, stereo = np.linspace(-1, 1, 64), np.linspace(-1, 1, 128).reshape(64, 2)
    for mix in (mono, stereo):
        before = mix.copy()
        output.add_to_mix(mix, z, (0.6, 0.8))
        assert np.array_equal(mix, before)
