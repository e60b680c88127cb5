"""Guitar Pro 6 (.gpx) and 7/8 (.gp): the GPIF reader.

No package on PyPI, Debian or npm ships .gpx/.gp files (searched: PyGuitarPro, apollotab,
music21, Debian's tuxguitar, npm's @coderline/alphatab), so the committed tests build them from the
third-party .gp5 files of PyGuitarPro's corpus (``gpif_writer``: the song written as GPIF, packed
as a .gp zip and as a BCFZ-compressed and an uncompressed .gpx) and check that each reads back as
the same scene as the .gp5: the same notes at the same times with the same articulations, and the
same events.  Real Guitar Pro 6/7/8 files (alphaTab's test data, for example) are checked when
``GUITAR_GPIF_CORPUS`` names a folder of them: each converts and labels one to one, and a song
present there as .gp5 and .gpx/.gp (``name.gp5`` beside ``name.gpx``) gives the same notes.
"""

from __future__ import annotations

import glob
import io
import os
import subprocess
import sys
import zipfile

import guitarpro
import pytest

from engine.score import ScoreError, scene_notes, score_to_scene
from engine.score.common import MAX_MEASURES, MAX_NOTES

from .conftest import check_scene, corpus, match_labels, no_overlap
from .gpif_writer import bcfs, bcfz, gp7, gpif, gpx
from .test_bad_input import _err


def _gp5_files(collecting: bool = False):
    return corpus("gp", "*.gp5", collecting)


def _key(n: dict) -> tuple:
    return (n["track"], n["string"], n["fret"], n["time"], n["end"], n["pitch"], n["dead"],
            tuple(n["articulations"]))


def _onset(n: dict) -> tuple:
    return (n["track"], n["string"], n["fret"], n["time"], n["pitch"])


def _events(scene) -> list:
    return [t["events"] for t in scene["tracks"]]


def _readable(path: str):
    try:
        return score_to_scene(path, all_instruments=True)
    except ScoreError:
        return None


@pytest.mark.parametrize("path", _gp5_files(collecting=True), ids=os.path.basename)
def test_gp5_written_as_gp7_and_gpx_reads_as_the_same_scene(path):
    """Constructed files (see the module's docstring): GP5 -> GPIF -> .gp/.gpx -> scene.  GP5's
    RSE note length (``durationPercent``, which GPIF does not carry) shortens some notes of the
    .gp5; where a file has such notes, their ends (and so the events) are not compared."""
    want = _readable(path)
    if want is None:
        pytest.skip("the .gp5 itself is refused (broken or no notes)")
    song = guitarpro.parse(path)
    rse = any(n.durationPercent < 1.0 for t in song.tracks for m in t.measures for v in m.voices
              for b in v.beats for n in b.notes)
    key = (lambda n: _key(n)[:4] + _key(n)[5:]) if rse else _key
    xml = gpif(song)
    for kind, data in (("gp7", gp7(xml)), ("gpx", gpx(xml)), ("gpx", gpx(xml, False))):
        got = score_to_scene(data, all_instruments=True)
        assert got.format == kind
        assert sorted(map(key, got.notes)) == sorted(map(key, want.notes)), (kind, path)
        if not rse:
            assert _events(got) == _events(want), (kind, path)
        assert [t["guitar"] for t in got["tracks"]] == [t["guitar"] for t in want["tracks"]]
        timing = ("bars", "bar_numbers", "beats", "beat_positions", "tempo")
        assert {k: got["score"][k] for k in timing} == {k: want["score"][k] for k in timing}


def test_effects_survive_the_trip():
    """The constructed files carry what the reader maps: the corpus's effect files hold bends,
    slides, hammer-ons, harmonics, palm mutes, dead notes, vibrato, grace notes, trills,
    tremolo picking, strokes and tapping, and all of them come back."""
    seen = set()
    for path in _gp5_files():
        if os.path.basename(path) not in ("Effects.gp5", "Slides.gp5", "Harmonics.gp5",
                                          "Strokes.gp5", "Demo v5.gp5", "001_Funky_Guy.gp5"):
            continue
        scene = score_to_scene(gpx(gpif(guitarpro.parse(path))), all_instruments=True)
        seen.update(a for n in scene.notes for a in n["articulations"])
    for a in ("bend", "slide_in", "slide_out", "hammer_on", "pull_off", "natural_harmonic",
              "artificial_harmonic", "palm_mute", "dead", "vibrato", "grace", "trill",
              "tremolo_picking", "strum_down", "strum_up", "tap"):
        assert any(s.startswith(a) for s in seen), (a, sorted(seen))


def test_tempo_automation_mid_bar():
    """A tempo automation halfway through bar 2 (240 quarter notes a minute, from 120) plays
    the rest of the song twice as fast."""
    path = next(p for p in _gp5_files() if os.path.basename(p) == "Chords.gp5")
    song = guitarpro.parse(path)
    want = score_to_scene(path, all_instruments=True)
    doc = gpif(song).replace(
        b"</Automations>", b"<Automation><Type>Tempo</Type><Linear>false</Linear><Bar>1</Bar>"
        b"<Position>0.5</Position><Value>240 2</Value></Automation></Automations>")
    fast = score_to_scene(gp7(doc), all_instruments=True)
    bar = 4 * 60.0 / song.tempo
    for a, b in zip(want.notes, fast.notes, strict=True):
        t = a["time"]
        expect = t if t <= 1.5 * bar else 1.5 * bar + (t - 1.5 * bar) / 2
        assert b["time"] == pytest.approx(expect, abs=1e-6)


# --- hostile and broken files ---------------------------------------------------------------

def _doc(body: str) -> bytes:
    return ('<?xml version="1.0"?>\n<GPIF>' + body + "</GPIF>").encode()


def test_broken_containers():
    xml = gpif(guitarpro.parse(next(p for p in _gp5_files()
                                    if os.path.basename(p) == "Chords.gp5")))
    good = gpx(xml)
    for cut in (5, 9, 40, len(good) // 2):
        _err(good[:cut])  # one line, whatever the cut
    raw = gpx(xml, compressed=False)
    _err(raw[:5000], "Guitar Pro 6")
    _err(b"BCFZ" + (2 ** 31).to_bytes(4, "little") + b"\0" * 64, "unpacked bytes")
    # a copy reaching before the start of the data
    _err(b"BCFZ" + (100).to_bytes(4, "little") + b"\xff" * 8,
         "BCFZ copy")
    _err(bcfs({"other.xml": b"<x/>"}), "holds no score.gpif")
    _err(bcfz(bcfs({"other.xml": b"<x/>"})), "holds no score.gpif")
    zipped = gp7(xml)
    _err(zipped[:len(zipped) // 2], "zip")
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        z.writestr("Content/other.xml", "<x/>")
    _err(buf.getvalue(), "without Content/score.gpif")


def test_zip_bomb_is_refused_before_it_unpacks():
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", zipfile.ZIP_DEFLATED, compresslevel=9) as z:
        z.writestr("Content/score.gpif", b"<GPIF>" + b" " * (40 * 1024 * 1024) + b"</GPIF>")
    assert len(buf.getvalue()) < 1024 * 1024
    _err(buf.getvalue(), "byte score")


@pytest.mark.parametrize("doc,text", [
    (b'<?xml version="1.0"?><!DOCTYPE g [<!ENTITY a "aaaaaaaaaa"><!ENTITY b "&a;&a;&a;&a;&a;'
     b'&a;&a;&a;&a;&a;"><!ENTITY c "&b;&b;&b;&b;&b;&b;&b;&b;&b;&b;">]><GPIF>&c;</GPIF>',
     "refused"),
    (b'<?xml version="1.0"?><!DOCTYPE g [<!ENTITY x SYSTEM "file:///etc/passwd">]>'
     b"<GPIF>&x;</GPIF>", "refused"),
    (b'<?xml version="1.0"?><GPIF><Score>', "not well-formed"),
    (b'<?xml version="1.0"?><score-partwise/>', "not <GPIF>"),
])
def test_hostile_xml(doc, text):
    for data in (gp7(doc), gpx(doc)):
        _err(data, text)


def test_a_billion_bars_and_a_million_notes():
    _err(gp7(_doc("<MasterBars>" + "<MasterBar><Time>4/4</Time></MasterBar>" * (MAX_MEASURES + 1)
                  + "</MasterBars>")), "bars")
    notes = "<Note><Properties/></Note>" * (MAX_NOTES + 1)
    _err(gp7(_doc(f"<Notes>{notes}</Notes>")), "notes")
    # one bar repeated 10^9 times
    path = next(p for p in _gp5_files() if os.path.basename(p) == "Chords.gp5")
    doc = gpif(guitarpro.parse(path)).replace(
        b"<MasterBar><Time>", b'<MasterBar><Repeat start="true" end="true" count="1000000000"/>'
        b"<Time>", 1)
    _err(gp7(doc), "repeats expand")


def test_cli_reads_gpx_and_refuses_a_broken_one(tmp_path):
    path = next(p for p in _gp5_files() if os.path.basename(p) == "Chords.gp5")
    good, bad = tmp_path / "chords.gpx", tmp_path / "broken.gpx"
    good.write_bytes(gpx(gpif(guitarpro.parse(path))))
    bad.write_bytes(good.read_bytes()[:30])
    env = {**os.environ, "PYTHONPATH": os.getcwd()}
    ok = subprocess.run([sys.executable, "-m", "cli.main", "scene", str(good), "-o",
                         str(tmp_path / "s.json")], capture_output=True, text=True, env=env,
                        timeout=120)
    assert ok.returncode == 0, ok.stderr
    no = subprocess.run([sys.executable, "-m", "cli.main", "scene", str(bad), "-o",
                         str(tmp_path / "t.json")], capture_output=True, text=True, env=env,
                        timeout=120)
    assert no.returncode == 2 and len(no.stderr.strip().splitlines()) == 1, no.stderr


# --- real Guitar Pro 6/7/8 files, where a folder of them is given ----------------------------

def _real(collecting: bool = False) -> list[str]:
    root = os.environ.get("GUITAR_GPIF_CORPUS")
    if not root:
        return []
    return sorted(glob.glob(os.path.join(root, "**", "*.gpx"), recursive=True)
                  + glob.glob(os.path.join(root, "**", "*.gp"), recursive=True))


@pytest.mark.skipif(not os.environ.get("GUITAR_GPIF_CORPUS"),
                    reason="GUITAR_GPIF_CORPUS names no folder of real .gpx/.gp files")
@pytest.mark.parametrize("path", _real(True) or ["none"], ids=os.path.basename)
def test_real_file_converts_and_labels_one_to_one(path):
    try:
        scene = score_to_scene(path, all_instruments=True)
    except ScoreError as exc:  # only files without any pitched track may be refused
        assert "no pitched track" in str(exc) or "no notes" in str(exc), str(exc)
        return
    check_scene(scene)
    labels = scene_notes(scene)
    assert not match_labels(scene, labels)
    assert len(labels) == len([n for n in scene.notes if not n["dead"]])
    no_overlap(labels)
    gp5 = os.path.splitext(path)[0] + ".gp5"
    if os.path.exists(gp5):
        want = score_to_scene(gp5)
        got = score_to_scene(path)
        assert sorted(map(_onset, got.notes)) == sorted(map(_onset, want.notes))
