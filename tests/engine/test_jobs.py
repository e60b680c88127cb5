"""A render on several threads (``jobs``, engine/mix.py): the same samples, bit for bit, as on one,
for both models, one track or several, mono or stereo, whatever the block size."""

from __future__ import annotations

import numpy as np
import pytest

import engine
from engine.mix import prepare

STRUM = [{"type": "fret", "time": 0.0, "string": 5, "fret": 3},
         {"type": "fret", "time": 0.0, "string": 2, "fret": 1},
         {"type": "strum", "time": 0.01, "spread": 0.02},
         {"type": "mute", "time": 0.12, "string": 6},
         {"type": "bend", "time": 0.05, "string": 3, "semitones": 1.0, "duration": 0.05}]
BASS = [{"type": "pluck", "time": 0.02, "string": 4},
        {"type": "fret", "time": 0.08, "string": 3, "fret": 2},
        {"type": "pluck", "time": 0.09, "string": 3}]


def _scenes(model: str) -> dict[str, dict]:
    return {
        "single": {"duration": 0.25, "model": model, "output": {"normalize": False},
                   "events": STRUM},
        "tracks": {"duration": 0.25, "model": model,
                   "output": {"normalize": False, "channels": 2},
                   "tracks": [{"guitar": {"preset": "electric"}, "events": STRUM, "pan": -0.3,
                               "effects": [{"type": "delay", "delay_s": 0.05}]},
                              {"guitar": {"preset": "bass"}, "events": BASS, "gain_db": -3.0},
                              {"events": STRUM[:3]}]},
    }


@pytest.mark.parametrize("model", ["fdtd", "waveguide"])
@pytest.mark.parametrize("kind", ["single", "tracks"])
def test_two_threads_give_the_samples_of_one(model, kind):
    sc = _scenes(model)[kind]
    one = engine.render(sc)
    assert np.any(one != 0.0)
    for jobs in (2, 3):
        assert engine.render(sc, jobs=jobs).tobytes() == one.tobytes()
    # streamed in blocks of an odd size on threads: what one thread streams
    raw = np.concatenate(list(engine.blocks(sc, block_frames=4096, raw=True)))
    streamed = np.concatenate(list(engine.blocks(sc, block_frames=333, raw=True, jobs=2)))
    assert streamed.tobytes() == raw.tobytes()


def test_more_threads_than_strings_and_a_silent_scene():
    sc = {"duration": 0.05, "events": [{"type": "pluck", "time": 0.0, "string": 1}]}
    assert engine.render(sc, jobs=8).tobytes() == engine.render(sc).tobytes()
    silent = {"duration": 0.05, "events": []}
    assert not np.any(engine.render(silent, jobs=2))


def test_the_threads_are_given_back_when_a_stream_stops_early():
    """A stream abandoned after its first block (a client gone) shuts its pool down on close."""
    import threading

    before = threading.active_count()
    mix = prepare(engine.parse_scene(_scenes("fdtd")["tracks"]), jobs=2)
    it = mix.blocks(512)
    next(it)
    assert threading.active_count() > before
    it.close()
    assert threading.active_count() == before


def test_a_failing_string_fails_the_render_on_threads():
    """An error in a voice's thread reaches the caller, as it would on one thread."""
    mix = prepare(engine.parse_scene(_scenes("waveguide")["single"]), jobs=2)

    def broken(voice, end):
        raise FloatingPointError(f"string {voice.index}: non-finite")

    mix.tracks[0].instrument.voice_frames = broken
    with pytest.raises(FloatingPointError, match="non-finite"):
        list(mix.blocks())


@pytest.mark.parametrize("jobs", [0, -1])
def test_jobs_must_be_positive(jobs):
    with pytest.raises(ValueError, match="jobs must be at least 1"):
        engine.render({"duration": 0.01, "events": []}, jobs=jobs)
