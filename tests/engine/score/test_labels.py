"""Labels of hand-written scenes: the pitch of the fret held when a string is attacked, from the
preset's tuning, changed by bends and harmonic touches; notes end at damps and next attacks."""

from __future__ import annotations

import jams
import pytest

from engine.score import scene_labels, scene_notes


def test_single_instrument_scene():
    scene = {"duration": 4.0, "events": [
        {"type": "fret", "time": 0.0, "string": 5, "fret": 3},
        {"type": "pluck", "time": 0.05, "string": 5},
        {"type": "hammer_on", "time": 0.5, "string": 5, "fret": 5},
        {"type": "pull_off", "time": 1.0, "string": 5, "fret": 5},
        {"type": "damp", "time": 1.5, "string": 5},
        {"type": "tap", "time": 2.0, "string": 3, "fret": 7},
        {"type": "bend", "time": 2.5, "string": 2, "semitones": 2.0, "duration": 0.1},
        {"type": "pluck", "time": 2.7, "string": 2},
        {"type": "harmonic", "time": 3.0, "string": 1, "fret": 12, "release": 3.2},
        {"type": "pluck", "time": 3.05, "string": 1},
    ]}
    notes = scene_notes(scene)
    got = [(n["string"], n["fret"], round(n["pitch"], 2), n["attack"]) for n in notes]
    assert got == [(5, 3, 48.0, "pluck"), (5, 5, 50.0, "hammer_on"), (5, 3, 48.0, "pull_off"),
                   (3, 7, 62.0, "tap"), (2, 0, 61.0, "pluck"), (1, 0, 76.0, "pluck")]
    assert notes[2]["duration"] == pytest.approx(0.5)  # damped at 1.5
    assert notes[4]["articulations"] == ["pluck", "prebend"]
    assert "harmonic_2" in notes[5]["articulations"]
    assert notes[5]["time"] + notes[5]["duration"] == pytest.approx(4.0)  # rings to the end


def test_strum_times_tracks_and_tuning():
    scene = {"duration": 2.0, "tracks": [
        {"name": "gtr", "guitar": {"preset": "electric", "tuning": ["D4", "A3", "F3", "C3",
                                                                   "G2", "C2"]},
         "events": [{"type": "strum", "time": 0.1, "spread": 0.05, "direction": "up",
                     "strings": [1, 2, 3]}]},
        {"name": "bass", "guitar": {"preset": "bass"},
         "events": [{"type": "fret", "time": 0.0, "string": 4, "fret": 5},
                    {"type": "pluck", "time": 0.2, "string": 4}]},
    ]}
    notes = scene_notes(scene)
    up = sorted((round(n["time"], 9), n["string"], n["pitch"]) for n in notes if n["track"] == 0)
    assert up == [(0.1, 1, 62.0), (0.125, 2, 57.0), (0.15, 3, 53.0)]
    (b,) = [n for n in notes if n["track"] == 1]
    assert b["pitch"] == 28 + 5 and b["track_name"] == "bass"


def test_slides_dead_touch_and_palm(tmp_path):
    scene = {"duration": 3.0, "events": [
        {"type": "fret", "time": 0.0, "string": 3, "fret": 5},
        {"type": "pluck", "time": 0.01, "string": 3},
        {"type": "slide", "time": 0.4, "string": 3, "from_fret": 5, "to_fret": 7,
         "duration": 0.1},  # a legato slide: a new note at its arrival
        {"type": "mute", "time": 1.0, "string": 4, "amount": 0.7, "release": 1.5},
        {"type": "pluck", "time": 1.0, "string": 4},
        {"type": "harmonic", "time": 2.0, "string": 6, "position": 0.381966, "release": 2.5},
        {"type": "pluck", "time": 2.0, "string": 6},
    ]}
    notes = scene_notes(scene)
    assert [(n["string"], n["fret"], n["attack"]) for n in notes] == [
        (3, 5, "pluck"), (3, 7, "slide"), (4, 0, "pluck")]
    assert notes[1]["time"] == pytest.approx(0.5)
    assert "palm_mute" in notes[2]["articulations"]
    jam = scene_labels(scene)
    path = tmp_path / "x.jams"
    jam.save(str(path))
    back = jams.load(str(path))
    anns = back.search(namespace="note_midi")
    assert [a.annotation_metadata.data_source for a in anns] == ["0", "1", "2", "3", "4", "5"]
    low_e = anns[0]
    assert low_e.sandbox["string"] == 6 and not low_e.data
    assert low_e.sandbox["unpitched"][0]["articulations"][-1] == "dead"
