"""MusicXML: music21's copies of the LilyPond MusicXML test suite, its tablature tests and a slice
of its corpus (.xml and compressed .mxl; `make test-data`), plus hostile documents."""

from __future__ import annotations

import io
import os
import zipfile

import pytest

from engine.score import ScoreError, scene_notes, score_to_scene

from .conftest import check_scene, corpus, match_labels, no_overlap
from .test_bad_input import _err


def _files(collecting: bool = False):
    return corpus("musicxml", "*", collecting)


def _notes_in(path: str) -> bool:
    """Whether the file has any pitched note that is not a rest (read plainly)."""
    data = open(path, "rb").read()
    if data[:2] == b"PK":
        z = zipfile.ZipFile(io.BytesIO(data))
        data = b"".join(z.read(n) for n in z.namelist() if not n.startswith("META-INF"))
    return any(t in data for t in (b"<pitch>", b"<pitch ", b"<fret>"))


@pytest.mark.parametrize("path", _files(collecting=True), ids=os.path.basename)
def test_musicxml_file_becomes_scene_with_matching_labels(path):
    if not _notes_in(path):
        with pytest.raises(ScoreError, match="no notes"):
            score_to_scene(path, all_instruments=True)
        return
    scene = score_to_scene(path, all_instruments=True, max_seconds=300)
    assert scene.format == "musicxml"
    check_scene(scene)
    labels = scene_notes(scene)
    assert not match_labels(scene, labels)
    assert len(labels) == len([n for n in scene.notes if not n["dead"]])
    no_overlap(labels)
    for w in scene.warnings:
        assert "track" in w, w


def test_tablature_is_kept():
    """71e-TabStaves: the guitar part's <string>/<fret> are played as written, on the staff's
    tuning (string 1 = the top line's string)."""
    path = next(p for p in _files() if os.path.basename(p) == "71e-TabStaves.xml")
    scene = score_to_scene(path, tracks=[1])
    tuning = scene["tracks"][0]["guitar"]["tuning"]
    assert tuning == ["E4", "B3", "G3", "D3", "A2", "E2"]
    from engine.score.common import note_midi

    for n in scene.notes:
        assert n["pitch"] == pytest.approx(note_midi(tuning[n["string"] - 1]) + n["fret"])


def test_repeats_are_played():
    path = next(p for p in _files() if os.path.basename(p) == "45b-RepeatWithAlternatives.xml")
    scene = score_to_scene(path, all_instruments=True)
    bars = [n["where"].split(",")[0] for n in scene.notes]
    assert bars.count("bar 1") == 2  # the first bar is played twice, each ending once
    assert bars.count("bar 2") == 1 and bars.count("bar 3") == 1


def test_only_guitars_by_default():
    path = next(p for p in _files() if os.path.basename(p) == "01a-Pitches-Pitches.xml")
    _err(path, "no guitar or bass track")


@pytest.mark.parametrize("doc,text", [
    (b'<?xml version="1.0"?><!DOCTYPE score-partwise [<!ENTITY a "aaaaaaaaaa"><!ENTITY b '
     b'"&a;&a;&a;&a;&a;&a;&a;&a;&a;&a;">]><score-partwise>&b;</score-partwise>', "refused"),
    (b'<?xml version="1.0"?><!DOCTYPE s [<!ENTITY x SYSTEM "file:///etc/passwd">]>'
     b"<score-partwise>&x;</score-partwise>", "refused"),
    (b'<?xml version="1.0"?><score-partwise><part-list>', "not well-formed"),
    (b'<?xml version="1.0"?><score-partwise>' + b"<part id='P1'>" + b"<measure><note><pitch>"
     b"<step>C</step><octave>4</octave></pitch><duration>1</duration></note></measure>"
     * 100_001 + b"</part></score-partwise>", "notes"),
])
def test_hostile_musicxml(doc, text):
    _err(doc, text)
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("score.musicxml", doc)
    _err(buf.getvalue(), text)
