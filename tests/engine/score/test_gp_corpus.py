"""Every Guitar Pro file of PyGuitarPro's own test corpus (files we did not write) that has notes
becomes a scene, and its labels agree one to one with the score's notes (ties merged)."""

from __future__ import annotations

import os

import guitarpro
import jams
import pytest

from engine.score import ScoreError, scene_labels, scene_notes, score_to_scene
from engine.score.gp import playback_order

from .conftest import check_scene, corpus, match_labels, no_overlap

BROKEN = {"chord-fail.gp3"}  # PyGuitarPro's own test expects this file to fail to parse


def _files(collecting: bool = False):
    return corpus("gp", "*.gp[345]", collecting)


def _played_notes(path: str, scene):
    """Every note of the score's pitched tracks that the scene kept, once per time its measure is
    played (PyGuitarPro's model, read apart from the importer)."""
    song = guitarpro.parse(path)
    order = playback_order(song.measureHeaders)
    kept = {t["name"] for t in scene["tracks"]}
    for t in song.tracks:
        if t.isPercussionTrack or (t.name or f"Track {t.number}") not in kept:
            continue
        for m in order:
            for voice in t.measures[m].voices:
                for beat in voice.beats:
                    yield from beat.notes


def _independent_count(path: str, scene) -> int:
    """Notes a player attacks: every note that is not a rest, a tie or a dead note, plus its
    grace note."""
    count = 0
    for note in _played_notes(path, scene):
        if note.type.name == "normal":
            count += 1
            g = note.effect.grace
            if g is not None and not g.isDead:
                count += 1
    return count


def test_corpus_is_there():
    files = _files()
    assert len(files) >= 60, files


@pytest.mark.parametrize("path", _files(collecting=True), ids=os.path.basename)
def test_gp_file_becomes_scene_with_matching_labels(path):
    name = os.path.basename(path)
    if name in BROKEN:
        with pytest.raises(ScoreError, match="truncated or corrupt"):
            score_to_scene(path, all_instruments=True)
        return
    song = guitarpro.parse(path)
    has_notes = any(n for t in song.tracks if not t.isPercussionTrack for m in t.measures
                    for v in m.voices for b in v.beats for n in b.notes)
    if not has_notes:
        with pytest.raises(ScoreError):
            score_to_scene(path, all_instruments=True)
        return
    scene = score_to_scene(path, all_instruments=True)
    check_scene(scene)
    labels = scene_notes(scene)
    bad = match_labels(scene, labels)
    assert not bad, bad[:3]
    pitched = [n for n in scene.notes if not n["dead"]]
    assert len(labels) == len(pitched)
    no_overlap(labels)
    # against the score itself: the attacked notes, less those the warnings say were left out or
    # merged, plus the extra attacks of trills and tremolo picking
    extra = sum(1 for n in scene.notes if n["repeat"])
    left_out = sum(1 for w in scene.warnings if "left out" in w and "track" in w
                   and "percussion" not in w)
    untied = sum(1 for w in scene.warnings if "played as a new note" in w)
    assert len(scene.notes) == _independent_count(path, scene) + _dead_count(path, scene) \
        + extra + untied - left_out, scene.warnings
    # every warning names bar, beat and track
    for w in scene.warnings:
        assert ("bar " in w and "beat " in w and "track" in w) or "percussion" in w, w


def _dead_count(path, scene) -> int:
    """Dead notes, and dead grace notes."""
    return sum((x.type.name == "dead") + (x.effect.grace is not None and x.effect.grace.isDead)
               for x in _played_notes(path, scene))


def test_labels_are_guitarset_jams(tmp_path):
    path = next(p for p in _files() if os.path.basename(p) == "Demo v5.gp5")
    scene = score_to_scene(path, all_instruments=True)
    jam = scene_labels(scene, title="Demo v5")
    out = tmp_path / "demo.jams"
    jam.save(str(out))
    back = jams.load(str(out))
    anns = back.search(namespace="note_midi")
    strings = sum(len(t["guitar"]["tuning"]) for t in scene["tracks"])
    assert len(anns) == strings
    total = 0
    for ann in anns:
        sb = ann.sandbox
        notes = sb["notes"]
        assert len(notes) == len(ann.data)
        planned = {(round(n["time"], 6), n["fret"]) for n in scene.notes
                   if n["track"] == sb["track"] and n["string"] == sb["string"]}
        for obs, n in zip(ann.data, notes, strict=True):  # each note's fret and articulations
            assert set(n) == {"fret", "attack", "articulations"}
            assert (round(obs.time, 6), n["fret"]) in planned
        n_strings = len(scene["tracks"][sb["track"]]["guitar"]["tuning"])
        assert ann.annotation_metadata.data_source == str(n_strings - sb["string"])
        total += len(ann.data)
    assert total == len([n for n in scene.notes if not n["dead"]])


def test_demo_tracks_tempo_and_repeats():
    path = next(p for p in _files() if os.path.basename(p) == "Demo v5.gp5")
    song = guitarpro.parse(path)
    scene = score_to_scene(path, all_instruments=True)
    assert [t["name"] for t in scene["tracks"]] == [t.name for t in song.tracks
                                                    if not t.isPercussionTrack]
    bass = scene["tracks"][[t.name for t in song.tracks].index("Bass")]
    assert bass["guitar"]["preset"] == "bass" and len(bass["guitar"]["tuning"]) == 4
    # measures 1-4 with a repeat of 1-3 (order 0 1 2 3 0 1 2 4 ...): bar 1 is played twice
    order = playback_order(song.measureHeaders)
    assert order[:8] == [0, 1, 2, 3, 0, 1, 2, 4]
    # D.S. al Coda at bar 37: back to the Segno (bar 18), then from "Da Coda" (bar 25) to the
    # Coda (bar 38), which plays to the end
    k = order.index(36)
    assert order[k + 1:k + 10] == [17, 18, 19, 20, 21, 22, 23, 24, 37]
    assert order[-1] == 48 and len(order) == 49 + 3 + 8
    assert not any("direction" in w for w in scene.warnings)
    bar1 = [n for n in scene.notes if n["where"].startswith("bar 1,")]
    firsts = sorted({round(n["time"], 3) for n in bar1})
    assert firsts[0] == 0.0 and max(firsts) > 4 * 60 / song.tempo * 3  # after bars 1-3 again


def test_only_guitars_and_basses_by_default():
    """Demo v5's 'Melody' is a choir (General MIDI 52): skipped by default and named in the
    warnings with the option that plays it; asked for by name, it is played."""
    path = next(p for p in _files() if os.path.basename(p) == "Demo v5.gp5")
    scene = score_to_scene(path)
    names = [t["name"] for t in scene["tracks"]]
    assert "Melody" not in names and "Bass" in names
    assert any("'Melody'" in w and "Choir Aahs" in w and "options.all_instruments" in w
               for w in scene.warnings), scene.warnings
    assert [t["name"] for t in score_to_scene(path, tracks=["Melody"])["tracks"]] == ["Melody"]
