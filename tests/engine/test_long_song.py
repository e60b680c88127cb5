"""Long scenes stream in bounded memory, and strings sleep between their notes
(benchmarks/long_song.py measures a 10-minute song)."""

from __future__ import annotations

import numpy as np
import pytest

import engine
from engine.fd.instrument import prepare
from engine.options import RenderOptions
from engine.output import FIXED_GAIN
from engine.scene import Scene
from engine.testing.measure import stream_peak
from engine.testing.scenes import song


@pytest.mark.slow  # a soak of random scenes or a long render; CI runs it
def test_streaming_memory_does_not_grow_with_the_duration():
    engine.warmup()
    stream_peak(song(30.0))  # first use: imports (pedalboard) and caches are not the song's
    short_s, short, _ = stream_peak(song(30.0))
    # the same notes in a scene four times as long (more events would add their own arrays)
    long_s, long, out = stream_peak({**song(30.0), "duration": 120.0})
    more_s, more, _ = stream_peak(song(120.0))  # four times the notes too
    print(f"peak traced memory: 30 s song {short / 1e6:.2f} MB ({short_s:.1f} s), the same notes "
          f"in 120 s {long / 1e6:.2f} MB ({long_s:.1f} s), 120 s of notes {more / 1e6:.2f} MB "
          f"({more_s:.1f} s); a 120 s output is {out / 1e6:.1f} MB")
    assert long < 1.05 * short + 0.2e6
    assert more < 0.25 * out


def test_a_string_sleeps_between_notes_and_wakes_for_the_next():
    """Two notes 3 s apart on one string: between them the string sleeps (fewer steps computed)
    and the second note sounds as without the skip, to within the decay threshold."""
    ev = [{"type": "fret", "time": 0.0, "string": 2, "fret": 3},
          {"type": "pluck", "time": 0.01, "string": 2},
          {"type": "damp", "time": 0.3, "string": 2},
          {"type": "fret", "time": 3.0, "string": 2, "fret": 5},
          {"type": "pluck", "time": 3.01, "string": 2}]
    sc = Scene.model_validate({"duration": 3.5, "events": ev, "output": {"body": "none"}})
    runs = {}
    for skip in (True, False):
        g = prepare(sc, RenderOptions(skip_decayed=skip))
        y = np.concatenate(list(g.blocks()))
        runs[skip] = (y, g.voices[0].steps_computed, g.voices[0].step)
    (y_on, computed, total), (y_off, _, _) = runs[True], runs[False]
    print(f"computed {computed} of {total} steps; largest difference "
          f"{np.max(np.abs(y_on - y_off)) * FIXED_GAIN:.2e} at the fixed gain")
    assert computed < 0.35 * total
    assert np.max(np.abs(y_off[int(3.0 * 44100):])) > 0.1
    np.testing.assert_allclose(y_on, y_off, rtol=0, atol=1e-5)
