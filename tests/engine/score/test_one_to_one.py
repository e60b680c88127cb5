"""The converter's notes and the labels of the scene it writes agree one to one, in the cases that
once parted them on real Guitar Pro files (alphaTab's test data): a pre-bend on a tied beat, a
grace note before a pre-bent note, and a pull-off past a finger still held."""

from __future__ import annotations

import guitarpro as gp

from engine.score import scene_notes, score_to_scene

from .conftest import check_scene, match_labels, no_overlap
from .helpers import song


def _pre_bend(start: float, peak: float):
    """A bend curve that starts ``start`` semitones up and rises to ``peak``."""
    return gp.BendEffect(points=[gp.BendPoint(0, round(2 * start)), gp.BendPoint(6, round(2 * peak)),
                                 gp.BendPoint(12, round(2 * peak))])


def _check(data: bytes):
    scene = score_to_scene(data)
    check_scene(scene)
    labels = scene_notes(scene)
    assert not match_labels(scene, labels)
    assert len(labels) == len([n for n in scene.notes if not n["dead"]])
    no_overlap(labels)
    return scene, labels


def test_a_pre_bend_on_a_tied_beat_leaves_the_attack_unbent():
    up = gp.BendEffect(points=[gp.BendPoint(0, 0), gp.BendPoint(3, 4), gp.BendPoint(12, 4)])
    data = song([[[(5, 7, {"bend": up})], [(5, 7, {"type": gp.NoteType.tie,
                                                   "bend": _pre_bend(2, 3)})], [], []]])
    scene, labels = _check(data)
    (note,) = scene.notes
    assert note["pitch"] == 52.0 and labels[0]["pitch"] == 52.0  # A2 + 7, struck unbent


def test_a_grace_note_before_a_pre_bent_note_is_struck_unbent():
    grace = gp.GraceEffect(duration=32, fret=5, isOnBeat=True)
    data = song([[[], [(3, 7, {"bend": _pre_bend(1, 1), "grace": grace})], [], []]])
    scene, labels = _check(data)
    assert [n["pitch"] for n in labels] == [60.0, 63.0]  # G3 + 5, then G3 + 7 + 1 bent


def test_a_pull_off_past_a_held_finger_lifts_it():
    """15 -> 17 -> 19 hammered, then pulled off to 15: the finger on 17 lifts with the pull."""
    h = {"hammer": True}
    data = song([[[(1, 15, h)], [(1, 17, h)], [(1, 19, h)], [(1, 15, None)]]])
    scene, labels = _check(data)
    assert [n["fret"] for n in labels] == [15, 17, 19, 15]
    (ev,) = [e for e in scene["tracks"][0]["events"] if e.get("fret") == 17
             and e["type"] == "hammer_on"]
    assert ev["release"] == labels[3]["time"]
