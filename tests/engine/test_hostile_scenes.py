"""Scenes inside every documented limit that once cost far more than their size, crashed on the way
to the kernels, or did nothing without saying so (issue 28): each class with variants."""

from __future__ import annotations

import numpy as np
import pytest
from pydantic import ValidationError

import engine
from engine.fd.controls import NEVER, string_controls
from engine.fd.instrument import prepare
from engine.performance import MAX_FINGERS, events_on
from engine.scene import MAX_RELEASE_S, Scene


def _fields(exc: ValidationError) -> list[str]:
    return [".".join(str(p) for p in e["loc"]) for e in exc.errors()]


def _invalid(scene: dict) -> str:
    with pytest.raises(ValidationError) as info:
        Scene.model_validate(scene)
    return str(info.value)


# ---- strict JSON types: what JSON says is not converted ------------------------------------

@pytest.mark.parametrize("scene, where", [
    ({"duration": True}, "duration"),
    ({"duration": "1"}, "duration"),
    ({"duration": 1, "sample_rate": "44100"}, "sample_rate"),
    ({"duration": 1, "sample_rate": 44100.0}, "sample_rate"),
    ({"duration": 1, "events": [{"type": "pluck", "time": 0, "string": 1.0}]}, "string"),
    ({"duration": 1, "events": [{"type": "pluck", "time": 0, "string": True}]}, "string"),
    ({"duration": 1, "events": [{"type": "pluck", "time": 0, "string": 1, "force": "2"}]},
     "force"),
    ({"duration": 1, "events": [{"type": "fret", "time": 0, "string": 1, "fret": 3.0}]}, "fret"),
    ({"duration": 1, "output": {"channels": True}}, "channels"),
    ({"duration": 1, "output": {"channels": 2.0}}, "channels"),
    ({"duration": 1, "output": {"normalize": 0}}, "normalize"),
    ({"duration": 1, "diagnostics": "true"}, "diagnostics"),
    ({"duration": 1, "guitar": {"preset": 3}}, "preset"),
])
def test_json_types_are_strict(scene, where):
    assert where in _invalid(scene)


def test_ints_are_still_numbers():
    sc = Scene.model_validate({"duration": 1, "events": [
        {"type": "pluck", "time": 0, "string": 1, "force": 2}]})
    assert sc.events[0].force == 2.0 and sc.duration == 1.0


# ---- times and names that once overflowed on the way to the kernels -------------------------

@pytest.mark.parametrize("event", [
    {"type": "fret", "time": 0, "string": 1, "fret": 2},
    {"type": "tap", "time": 0, "string": 1, "fret": 2},
    {"type": "slide", "time": 0, "string": 1, "from_fret": 2, "to_fret": 4},
    {"type": "bend", "time": 0, "string": 1, "semitones": 1},
    {"type": "harmonic", "time": 0, "string": 1, "fret": 12},
    {"type": "mute", "time": 0, "string": 1},
])
@pytest.mark.parametrize("release", [1e7, 1e15, 1e300])
def test_release_is_bounded(event, release):
    text = _invalid({"duration": 0.1, "events": [{**event, "release": release}]})
    assert "release" in text and "1000000" in text


def test_the_latest_release_renders():
    # the bound itself: every step count stays inside int64 at the highest internal rate
    x = engine.render({"duration": 0.02, "sample_rate": 96000, "quality": "high", "events": [
        {"type": "fret", "time": 0, "string": 1, "fret": 2, "release": MAX_RELEASE_S},
        {"type": "mute", "time": 0, "string": 2, "release": MAX_RELEASE_S},
        {"type": "bend", "time": 0, "string": 1, "semitones": 1, "release": MAX_RELEASE_S},
        {"type": "pluck", "time": 0, "string": 1}]})
    assert np.all(np.isfinite(x)) and np.max(np.abs(x)) > 0


@pytest.mark.parametrize("note", ["E99999", "E-99999", "C100", "A" + "9" * 5000, "E2.5", "E"])
def test_note_names_with_absurd_octaves_are_refused(note):
    text = _invalid({"duration": 1, "guitar": {"tuning": [note] + ["E2"] * 5}})
    assert "tuning" in text
    text = _invalid({"duration": 1, "guitar": {"strings": [{"string": 1, "note": note}]}})
    assert "note" in text


# ---- output that no decoder would open --------------------------------------------------------

@pytest.mark.parametrize("rate", [65536, 70001, 95999])
def test_flac_refuses_rates_its_frame_header_cannot_carry(rate):
    text = _invalid({"duration": 0.1, "sample_rate": rate, "output": {"format": "flac"}})
    assert "sample_rate" in text and "65535" in text and "multiple of 10" in text
    Scene.model_validate({"duration": 0.1, "sample_rate": rate, "output": {"format": "wav"}})


@pytest.mark.parametrize("fmt", ["wav", "flac", "ogg"])
@pytest.mark.parametrize("duration, rate", [(1e-6, 44100), (1e-5, 22050), (5e-6, 96000)])
def test_a_scene_of_no_samples_is_refused(fmt, duration, rate):
    text = _invalid({"duration": duration, "sample_rate": rate, "output": {"format": fmt}})
    assert "duration" in text and "one sample" in text


# ---- bounded lists ------------------------------------------------------------------------------

@pytest.mark.parametrize("strings, word", [
    ([1] * 125_000, "at most 12"), ([1, 2, 1], "at most once"), ([], "non-empty"),
    ([1, 7], "outside 1..6"),
])
def test_strum_strings_are_bounded_and_unique(strings, word):
    text = _invalid({"duration": 1, "events": [{"type": "strum", "time": 0, "strings": strings}]})
    assert "strings" in text and word in text


@pytest.mark.parametrize("field, value", [
    ("tuning", ["E2"] * 13), ("strings", [{"string": 1}] * 13), ("preset", "x" * 65),
])
def test_guitar_lists_and_names_are_bounded(field, value):
    assert field in _invalid({"duration": 1, "guitar": {field: value}})


# ---- contacts that stack are merged, so the cost stays linear in the events ---------------------

def _controls(scene: dict, string: int = 1):
    sc = Scene.model_validate(scene)
    g = prepare(sc)
    v = next(v for v in g.voices if v.index == string)
    return string_controls(events_on(sc, 6, string), g.preset, string, v.model.h, v.model.n,
                           float(sc.sample_rate) * v.oversample, 1.0, lambda c: 1.0)


def _most_at_once(on: np.ndarray, off: np.ndarray) -> int:
    return max((int(np.sum((on <= s) & (s < off))) for s in on), default=0)


@pytest.mark.parametrize("n", [2, 30, 200])
@pytest.mark.parametrize("kind", ["mute", "all-strings mute", "harmonic"])
def test_one_palm_and_one_touch_per_string_at_once(n, kind):
    if kind == "harmonic":
        evs = [{"type": "harmonic", "time": 0.09 * i / n, "string": 1, "fret": 5 + i % 8}
               for i in range(n)]
    else:
        evs = [{"type": "mute", "time": 0.09 * i / n, "amount": 0.3 + 0.7 * (i % 2)}
               | ({} if kind == "all-strings mute" else {"string": 1}) for i in range(n)]
    ctl = _controls({"duration": 0.1, "events": evs + [{"type": "pluck", "time": 0, "string": 1}]})
    a = ctl.arrays
    assert _most_at_once(a.dp_on, a.dp_off) == 1
    assert a.dp_on.size <= n and a.dp_off[-1] == NEVER  # the last one rests on


@pytest.mark.parametrize("n", [3, 10, 200])
def test_hammer_ons_keep_at_most_a_hand_of_fingers(n):
    evs = [{"type": "hammer_on", "time": 0.09 * i / n, "string": 1, "fret": 1 + i % 12}
           for i in range(n)]
    a = _controls({"duration": 0.1, "events": evs}).arrays
    assert _most_at_once(a.fs_on, a.fs_rel) == min(n, MAX_FINGERS)


def test_a_later_mute_takes_over_from_its_start():
    a = _controls({"duration": 0.2, "events": [
        {"type": "mute", "time": 0.0, "string": 1, "amount": 0.2},
        {"type": "mute", "time": 0.1, "string": 1, "amount": 0.9, "release": 0.15}]}).arrays
    assert a.dp_off[0] == a.dp_on[1] and a.dp_r[1] > a.dp_r[0]


# ---- a pull-off that finds no finger says so ---------------------------------------------------

def _warnings(events: list[dict], duration: float = 0.3) -> list[str]:
    sc = {"duration": duration, "events": [{"type": "pluck", "time": 0, "string": 3}, *events]}
    both = engine.scene_warnings(Scene.model_validate(sc)), engine.blocks(sc).warnings
    assert both[0] == both[1]
    return [w for w in both[0] if "pull-off" in w]


PO = {"type": "pull_off", "time": 0.2, "string": 3, "fret": 7}


@pytest.mark.parametrize("before", [
    [],  # no finger at all
    [{"type": "fret", "time": 0.0, "string": 3, "fret": 5}],  # a finger on another fret
    [{"type": "fret", "time": 0.0, "string": 3, "fret": 7, "release": 0.1}],  # lifted before
    [{"type": "tap", "time": 0.0, "string": 3, "fret": 7},
     {"type": "fret", "time": 0.1, "string": 3, "fret": 3}],  # replaced by another fret
    [{"type": "fret", "time": 0.0, "string": 4, "fret": 7}],  # on another string
    [{"type": "fret", "time": 0.0, "string": 3, "fret": 7},
     {"type": "pull_off", "time": 0.1, "string": 3, "fret": 7}],  # already pulled off
])
def test_a_pull_off_with_no_finger_warns(before):
    warnings = _warnings([*before, PO])
    assert len(warnings) == 1
    assert warnings[0].startswith("string 3: the pull-off at 0.2 s finds no finger on fret 7")


@pytest.mark.parametrize("before", [
    [{"type": "fret", "time": 0.0, "string": 3, "fret": 7}],
    [{"type": "fret", "time": 0.0, "string": 3, "fret": 5},
     {"type": "hammer_on", "time": 0.1, "string": 3, "fret": 7}],
    [{"type": "slide", "time": 0.0, "string": 3, "from_fret": 5, "to_fret": 7}],
])
def test_a_pull_off_from_a_held_fret_does_not_warn(before):
    assert _warnings([*before, PO]) == []
