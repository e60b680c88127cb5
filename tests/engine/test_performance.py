"""``engine.performance``: the player's gestures, one rule for both models, the live session, the
score importers and labels, the cost estimate and the command line."""

from __future__ import annotations

import copy

import engine
from engine.cost import expanded_event_count
from engine.performance import expand, per_string, strum_times, truncate
from engine.scene import Pluck, parse_scene
from engine.score.labels import scene_notes


def test_a_down_strum_goes_from_the_low_string_up_with_the_spread_divided_evenly():
    assert strum_times(1.0, None, "down", 0.05, 6) == [
        (6, 1.0), (5, 1.01), (4, 1.02), (3, 1.03), (2, 1.04), (1, 1.05)]
    assert strum_times(0.0, [2, 4, 3], "up", 0.1, 6) == [(2, 0.0), (3, 0.05), (4, 0.1)]
    assert strum_times(0.0, [5], "down", 0.1, 6) == [(5, 0.0)]


def test_a_strum_and_a_string_less_mute_or_damp_act_on_every_string():
    sc = parse_scene({"duration": 1.0, "events": [
        {"type": "strum", "time": 0.0, "spread": 0.05}, {"type": "mute", "time": 0.5},
        {"type": "damp", "time": 0.8}]})
    out = expand(sc, 6)
    plucks = [e for e in out if isinstance(e, Pluck)]
    assert [(p.string, p.time) for p in plucks] == strum_times(0.0, None, "down", 0.05, 6)
    assert sorted(e.string for e in out if e.type == "mute") == [1, 2, 3, 4, 5, 6]
    assert sorted(e.string for e in out if e.type == "damp") == [1, 2, 3, 4, 5, 6]
    # the cost estimate counts what the engine makes of them
    assert expanded_event_count(sc) == len(out) == 18
    assert [e.string for e in per_string(sc.events[0], 6)] == [6, 5, 4, 3, 2, 1]


def test_labels_place_a_strums_notes_where_the_engine_plucks():
    scene = {"duration": 1.0, "events": [
        {"type": "strum", "time": 0.1, "strings": [1, 2, 3], "direction": "up", "spread": 0.04}]}
    starts = sorted((n["string"], n["time"]) for n in scene_notes(scene))
    assert starts == sorted(strum_times(0.1, [1, 2, 3], "up", 0.04, 6))


def test_a_cut_scene_renders_as_the_start_of_the_whole_one():
    scene = {"duration": 0.3, "quality": "draft", "output": {"normalize": False},
             "events": [{"type": "fret", "time": 0.0, "string": 2, "fret": 3, "release": 0.25},
                        {"type": "pluck", "time": 0.01, "string": 2},
                        {"type": "pluck", "time": 0.2, "string": 1}]}
    cut = truncate(copy.deepcopy(scene), 0.15)
    assert cut["duration"] == 0.15 and len(cut["events"]) == 2
    assert cut["events"][0]["release"] == 0.25  # a release past the cut stays (the schema allows it)
    whole, short = engine.render(scene), engine.render(cut)
    assert (short == whole[:len(short)]).all()


def test_truncate_leaves_what_is_not_a_scene_to_the_validation():
    assert truncate({"duration": "long"}, 1.0) == {"duration": "long"}
    assert truncate({"duration": 2.0, "events": ["x"]}, 1.0) == {"duration": 1.0, "events": ["x"]}
    tracks = {"duration": 2.0, "tracks": [{"events": [{"type": "pluck", "time": 1.5}]}, 7]}
    assert truncate(tracks, 1.0) == {"duration": 1.0, "tracks": [{"events": []}, 7]}
