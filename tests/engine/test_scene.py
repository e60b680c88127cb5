"""Validation at the edge: every bad input names its field and the allowed range."""

import pytest
from pydantic import ValidationError

import engine

GOOD = {"duration": 1.0, "events": [{"type": "pluck", "time": 0.0, "string": 1}]}


def _bad(patch):
    sc = {**GOOD, **patch}
    with pytest.raises(ValidationError) as e:
        engine.render(sc)
    return str(e.value)


@pytest.mark.parametrize("patch,words", [
    ({"duration": 0}, ["duration", "greater than 0"]),
    ({"duration": 1e9}, ["duration", "less than or equal"]),
    ({"sample_rate": 8000}, ["sample_rate", "22050"]),
    ({"events": [{"type": "pluck", "time": 0, "string": 7}]}, ["string", "1..6"]),
    ({"events": [{"type": "pluck", "time": 0, "string": 0}]}, ["string", "greater than or equal"]),
    ({"events": [{"type": "pluck", "time": 2.0, "string": 1}]}, ["time", "< 1.0"]),
    ({"events": [{"type": "pluck", "time": -1, "string": 1}]}, ["time", "greater than or equal"]),
    ({"events": [{"type": "pluck", "time": 0, "string": 1, "force": -1}]}, ["force"]),
    ({"events": [{"type": "pluck", "time": 0, "string": 1, "force": 100}]}, ["force", "20"]),
    ({"events": [{"type": "pluck", "time": 0, "string": 1, "position": 1.5}]}, ["position"]),
    ({"events": [{"type": "fret", "time": 0, "string": 1, "fret": 22}]}, ["fret", "0..20"]),
    ({"events": [{"type": "tap", "time": 0, "string": 1, "fret": 0}]}, ["fret"]),
    ({"events": [{"type": "fret", "time": 0.5, "string": 1, "fret": 2, "release": 0.2}]},
     ["release", "after"]),
    ({"events": [{"type": "wobble", "time": 0, "string": 1}]}, ["pluck", "fret", "tap"]),
    ({"guitar": {"preset": "banjo"}}, ["preset", "steel-acoustic"]),
    ({"guitar": {"tuning": ["E2"]}}, ["tuning", "6 notes expected"]),
    ({"guitar": {"tuning": ["H2"] * 6}}, ["note name"]),
    ({"output": {"format": "mp3"}}, ["format", "wav"]),
    ({"duration": float("nan")}, ["duration"]),
    ({"events": [{"type": "pluck", "time": 0, "string": 1, "force": float("inf")}]}, ["force"]),
    ({"extra": 1}, ["extra"]),
])
def test_bad_input_names_the_field(patch, words):
    msg = _bad(patch)
    for w in words:
        assert w in msg, msg


def test_overrides_apply():
    sc = engine.parse_scene({**GOOD, "guitar": {"tuning": ["D4", "B3", "G3", "D3", "G2", "D2"],
                                                 "frets": 22, "action_12th_m": 0.0025}})
    p = sc.preset()
    assert p.strings[5].note == "D2" and p.frets == 22 and p.action_12th_m == 0.0025
