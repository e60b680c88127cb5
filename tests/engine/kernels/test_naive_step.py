"""The compiled step against the plain-NumPy reference of one complete time step
(``engine.testing.naive_step``): the same state in, the state out within 1e-12 of its scale, on
scenes that between them bring every column and contact into play, step by step over the stretch
where they act."""

from dataclasses import replace

import pytest

from engine import QUALITY, RenderOptions
from engine.testing.naive_step import compare_steps
from engine.testing.scenes import fret, pluck, scene, tap

TOL = 1e-12

# name: (events, seconds compared from the start, column kinds that must have acted)
CASES = {
    "pluck": ([pluck(6, force=8.0)], 0.004, {"kc"}),
    "fretted": ([fret(3, 5), pluck(3, time=0.003, force=4.0)], 0.008, {"finger", "rigid"}),
    "tap": ([tap(2, 7, velocity=1.0)], 0.006, {"finger", "rigid"}),
    "slam": ([tap(1, 12, force=10.0, velocity=5.0)], 0.004, {"finger", "sav", "rigid"}),
    "slide": ([fret(3, 5), pluck(3, time=0.002, force=4.0),
               {"type": "slide", "time": 0.003, "string": 3, "from_fret": 5, "to_fret": 7,
                "duration": 0.003}], 0.008, {"finger", "rigid"}),
    "harmonic": ([{"type": "harmonic", "time": 0.0, "string": 1, "fret": 12, "release": 0.004},
                  pluck(1, time=0.001, force=2.0)], 0.006, {"damper"}),
    "palm-mute": ([{"type": "mute", "time": 0.0, "string": 6}, pluck(6, time=0.001, force=4.0)],
                  0.004, {"damper"}),
    "bend": ([fret(2, 7), pluck(2, time=0.001, force=4.0),
              {"type": "bend", "time": 0.002, "string": 2, "semitones": 1.0, "duration": 0.003}],
             0.006, {"finger", "rigid"}),
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_step_matches_the_naive_reference(name):
    events, seconds, kinds = CASES[name]
    r = compare_steps(scene(events, seconds), seconds)
    assert r["steps"] > 100
    assert kinds <= set(r["kinds"]), r["kinds"]  # the columns the case is for did act
    assert r["decisions"] == 0, r
    for field, err in r["worst"].items():
        assert err <= TOL, (field, r)


def test_penalty_frets_match_the_naive_reference():
    q = replace(QUALITY["standard"], fret_mode=2, calibrate_frets=False)
    r = compare_steps(scene([fret(3, 5), pluck(3, time=0.002, force=4.0)], 0.006), 0.006,
                      RenderOptions(quality=q))
    assert r["kinds"].get("sav", 0) > 100, r["kinds"]
    assert r["decisions"] == 0, r
    for field, err in r["worst"].items():
        assert err <= TOL, (field, r)
