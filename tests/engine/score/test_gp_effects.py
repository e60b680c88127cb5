"""Each Guitar Pro effect, in a small file written here, becomes the articulation API.md names,
and the labels read from the scene agree with the score's notes."""

from __future__ import annotations

import guitarpro as gp
import pytest

from engine.score import scene_notes, score_to_scene

from .conftest import check_scene, match_labels
from .helpers import song


def _scene(measures, **kw):
    sc = score_to_scene(song(measures, **kw))
    check_scene(sc)
    assert not match_labels(sc, scene_notes(sc))
    return sc


def _ev(sc, kind, string=None):
    return [e for e in sc["tracks"][0]["events"] if e["type"] == kind
            and (string is None or e.get("string") == string)]


def _bend(points):
    return gp.BendEffect(type=gp.BendType.bendRelease, value=100,
                         points=[gp.BendPoint(p, v) for p, v in points])


def test_plain_notes_end_with_damp_and_let_ring_does_not():
    sc = _scene([[[(1, 3, None)], [], [(2, 5, {"letRing": True})], []]])
    assert {e["string"] for e in _ev(sc, "damp")} == {1}
    assert _ev(sc, "damp")[0]["time"] == pytest.approx(0.5)


def test_bend_release_curve():
    sc = _scene([[[(3, 7, {"bend": _bend([(0, 0), (3, 4), (6, 4), (9, 0), (12, 0)])})]]])
    (b,) = _ev(sc, "bend", 3)
    assert b["semitones"] == pytest.approx(2.0)  # 4 quarter tones
    assert b["time"] == pytest.approx(0.0) and b["duration"] == pytest.approx(0.125)
    assert b["release"] + b["duration"] == pytest.approx(0.375, abs=1e-6)


def test_hammer_on_and_pull_off():
    sc = _scene([[[(2, 5, {"hammer": True})], [(2, 7, {"hammer": True})], [(2, 5, None)], []]])
    h, = [e for e in _ev(sc, "hammer_on", 2) if e["fret"] == 7]
    p, = _ev(sc, "pull_off", 2)
    assert h["time"] == pytest.approx(0.5) and p["time"] == pytest.approx(1.0) and p["fret"] == 7
    assert len(_ev(sc, "pluck")) == 1
    assert [n["attack"] for n in scene_notes(sc)] == ["pluck", "hammer_on", "pull_off"]


def test_legato_slide_and_slides_in_and_out():
    sc = _scene([[[(3, 5, {"slides": [gp.SlideType.legatoSlideTo]})], [(3, 9, None)],
                  [(4, 7, {"slides": [gp.SlideType.intoFromBelow]})],
                  [(5, 8, {"slides": [gp.SlideType.outDownwards]})]]])
    sl = {(e["string"], e["from_fret"], e["to_fret"]) for e in _ev(sc, "slide")}
    assert {(3, 5, 9), (4, 4, 7), (5, 8, 3)} <= sl
    assert len(_ev(sc, "pluck", 3)) == 1
    notes = scene_notes(sc)
    assert [n["fret"] for n in notes] == [5, 9, 7, 8]


def test_harmonics_natural_artificial_pinch():
    sc = _scene([[[(1, 12, {"harmonic": gp.NaturalHarmonic()})],
                  [(2, 7, {"harmonic": gp.NaturalHarmonic()})],
                  [(3, 2, {"harmonic": gp.ArtificialHarmonic()})],
                  [(4, 5, {"harmonic": gp.PinchHarmonic()})]]])
    notes = scene_notes(sc)
    assert [round(n["pitch"], 2) for n in notes] == [76.0, 78.02, 69.0, 82.86]
    assert [a for n in notes for a in n["articulations"] if a.startswith("harmonic")] == [
        "harmonic_2", "harmonic_3", "harmonic_2", "harmonic_5"]


def test_palm_mute_dead_note_vibrato_staccato():
    sc = _scene([[[(6, 0, {"palmMute": True})], [(5, 3, {"type": gp.NoteType.dead})],
                  [(4, 2, {"vibrato": True})], [(3, 4, {"staccato": True})]]])
    assert _ev(sc, "mute", 6)[0]["release"] == pytest.approx(0.5)
    notes = scene_notes(sc)
    assert [n["string"] for n in notes] == [6, 4, 3]  # the dead note sounds no pitch
    assert _ev(sc, "vibrato", 4)
    assert _ev(sc, "damp", 3)[0]["time"] == pytest.approx(1.75)


def test_grace_trill_tremolo():
    grace = gp.GraceEffect(duration=32, fret=3, transition=gp.GraceEffectTransition.hammer)
    trill = gp.TrillEffect(fret=7, duration=gp.Duration(16))
    trem = gp.TremoloPickingEffect(duration=gp.Duration(16))
    sc = _scene([[[(1, 5, {"grace": grace})], [(2, 5, {"trill": trill})],
                  [(3, 2, {"tremoloPicking": trem})], []]])
    notes = scene_notes(sc)
    s1 = [n["fret"] for n in notes if n["string"] == 1]
    s2 = [n["fret"] for n in notes if n["string"] == 2]
    s3 = [n for n in notes if n["string"] == 3]
    assert s1 == [3, 5] and s2 == [5, 7, 5, 7] and len(s3) == 4
    assert [n["attack"] for n in notes if n["string"] == 2][1:] == ["hammer_on", "pull_off",
                                                                     "hammer_on"]


def test_stroke_becomes_strum():
    def down(beat):
        beat.effect.stroke = gp.BeatStroke(gp.BeatStrokeDirection.down, 16)
    sc = _scene([[[(1, 0, None), (2, 1, None), (3, 0, None), (4, 2, None), (5, 3, None)]]],
                beat_effects={(0, 0): down})
    (st,) = _ev(sc, "strum")
    assert st["strings"] == [1, 2, 3, 4, 5] and st["direction"] == "down"
    times = {n["string"]: n["time"] for n in scene_notes(sc)}
    assert times[5] == pytest.approx(0.0) and times[1] == pytest.approx(st["spread"])


def test_tie_tempo_capo_and_seven_strings():
    tie = {"type": gp.NoteType.tie}
    sc = _scene([[[(1, 3, None)], [(1, 3, tie)], [], []]], tempo=60, capo=2,
                strings=[64, 59, 55, 50, 45, 40, 35])
    notes = scene_notes(sc)
    assert len(notes) == 1 and notes[0]["duration"] == pytest.approx(2.0)  # two beats at 60 bpm
    g = sc["tracks"][0]["guitar"]
    assert g["tuning"] == ["F#4", "C#4", "A3", "E3", "B2", "F#2", "C#2"]
    assert notes[0]["pitch"] == 64 + 2 + 3


def test_triplet_feel_swings_eighths():
    def eighths(m):
        return [[(1, 0, None)]] * 2
    s = gp.Song()
    data = song([eighths(0)])
    sc0 = score_to_scene(data)
    assert [n["time"] for n in sc0.notes] == pytest.approx([0.0, 0.5])
    # the swing rule on positions: an eighth off the beat lands two thirds into it
    from engine.score.gp import _swing
    assert _swing(480, gp.TripletFeel.eighth) == pytest.approx(640)
    assert _swing(960 + 480, gp.TripletFeel.eighth) == pytest.approx(960 + 640)
    assert _swing(240, gp.TripletFeel.sixteenth) == pytest.approx(320)
    del s


def test_sources_path_bytes_file_object_and_json(tmp_path):
    import json

    data = song([[[(1, 3, None)], [(2, 5, None)]]])
    p = tmp_path / "x.gp5"
    p.write_bytes(data)
    a = score_to_scene(str(p))
    b = score_to_scene(data)
    with open(p, "rb") as f:
        c = score_to_scene(f)
    # the file's name is kept where there is one (a path, a file object)
    assert [x["score"].pop("source") for x in (a, b, c)] == ["x.gp5", "", "x.gp5"]
    assert a == b == c and a.notes == c.notes and a.format == "gp"
    assert json.loads(json.dumps(a)) == dict(a)  # the scene is plain JSON
    only = score_to_scene(data, tracks=[1], presets={1: "nylon-classical"})
    assert only["tracks"][0]["guitar"]["preset"] == "nylon-classical"
