"""Bars, beats and tempo of a converted score (``scene["score"]``, ``engine.scene.ScoreInfo``):
in seconds as played (repeats unfolded, tempo changes, tempo scale, the max_seconds cut), and as
the labels' ``beat`` and ``tempo`` annotations."""

from __future__ import annotations

import io
import os

import guitarpro as gp
import jams
import pretty_midi
import pytest

import engine
from engine.score import scene_labels, score_to_scene

from .helpers import song

CORPUS = os.path.join(os.path.dirname(__file__), "..", "..", "..", ".cache", "score-corpus")


def _repeat_song(tempo_change_bar: int = 2) -> bytes:
    """Four 4/4 bars at 120 bpm, bars 1-2 repeated once, 60 bpm from the first beat of bar
    ``tempo_change_bar`` (1-based) on."""
    data = song([[[(1, 0, None)]] * 4] * 4, tempo=120)
    s = gp.parse(io.BytesIO(data))
    s.measureHeaders[0].isRepeatOpen = True
    s.measureHeaders[1].repeatClose = 1
    beat = s.tracks[0].measures[tempo_change_bar - 1].voices[0].beats[0]
    beat.effect.mixTableChange = gp.MixTableChange(tempo=gp.MixTableItem(value=60))
    buf = io.BytesIO()
    gp.write(s, buf, version=(5, 1, 0))
    return buf.getvalue()


def test_bars_and_beats_as_played():
    info = score_to_scene(_repeat_song())["score"]
    # order 1 2 1 2 3 4; bar 1 at 120 bpm (2 s), then 60 bpm (4 s a bar) from bar 2 on: bar 1
    # carries no tempo of its own, so it is played again at 60
    assert info["bar_numbers"] == [1, 2, 1, 2, 3, 4]
    assert info["bars"] == pytest.approx([0, 2, 6, 10, 14, 18])
    assert info["beat_positions"] == [1, 2, 3, 4] * 6
    assert info["beats"][:6] == pytest.approx([0, 0.5, 1, 1.5, 2, 3])
    assert [(m["time"], m["bpm"]) for m in info["tempo"]] == [(0, 120), (2, 60)]
    assert info["source"] == "" and info["format"] == "gp"
    engine.Scene.model_validate(dict(score_to_scene(_repeat_song())))


def test_tempo_scale_and_max_seconds():
    fast = score_to_scene(_repeat_song(), tempo_scale=2.0, max_seconds=5.0)["score"]
    assert fast["bars"] == pytest.approx([0, 1, 3])  # half the times, cut at 5 s
    assert fast["bar_numbers"] == [1, 2, 1]
    assert max(fast["beats"]) < 5.0
    assert [(m["time"], m["bpm"]) for m in fast["tempo"]] == [(0, 240), (1, 120)]


def test_compound_meter_counts_dotted_beats():
    data = song([[[(1, 0, None)]] * 3] * 2, tempo=120)
    s = gp.parse(io.BytesIO(data))
    for h in s.measureHeaders:
        h.timeSignature = gp.TimeSignature(6, gp.Duration(8))
    buf = io.BytesIO()
    gp.write(s, buf, version=(5, 1, 0))
    info = score_to_scene(buf.getvalue())["score"]
    assert info["beat_positions"] == [1, 2, 1, 2]  # two dotted quarters a bar, as pretty_midi
    assert info["beats"] == pytest.approx([0, 0.75, 1.5, 2.25])


def test_jams_beat_and_tempo_annotations(tmp_path):
    scene = score_to_scene(_repeat_song())
    path = tmp_path / "x.jams"
    scene_labels(scene).save(str(path))
    jam = jams.load(str(path))  # validates
    (beat,) = jam.search(namespace="beat")
    (tempo,) = jam.search(namespace="tempo")
    assert [o.value for o in beat.data][:8] == [1, 2, 3, 4, 1, 2, 3, 4]
    assert [o.time for o in beat.data] == pytest.approx(scene["score"]["beats"])
    assert [(o.time, o.duration, o.value) for o in tempo.data] == [
        (0, 2, 120), (2, scene["duration"] - 2, 60)]
    # a scene written by hand has no score: notes only
    hand = scene_labels({"duration": 1.0, "events": [{"type": "pluck", "time": 0.0,
                                                      "string": 1}]})
    assert not hand.search(namespace="beat") and not hand.search(namespace="tempo")


def test_midi_beats_are_pretty_midis():
    path = os.path.join(CORPUS, "midi", "k525short.mid")
    if not os.path.exists(path):
        pytest.skip("score corpus not fetched (make test-data)")
    pm = pretty_midi.PrettyMIDI(path)
    info = score_to_scene(path, all_instruments=True, tempo_scale=2.0)["score"]
    n = len(info["beats"])
    assert n > 8
    assert info["beats"] == pytest.approx([b / 2 for b in pm.get_beats()[:n]], abs=1e-6)
    assert info["bars"] == pytest.approx([b / 2 for b in pm.get_downbeats()[:len(info["bars"])]],
                                         abs=1e-6)
    downs = [t for t, p in zip(info["beats"], info["beat_positions"], strict=True) if p == 1]
    assert downs == pytest.approx(info["bars"][:len(downs)])
    assert info["tempo"][0]["bpm"] == pytest.approx(2 * pm.get_tempo_changes()[1][0], rel=1e-4)
