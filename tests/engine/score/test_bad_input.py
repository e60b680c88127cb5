"""Bad input: truncated, empty, zero-length, wrong-type and hostile files are a ScoreError (a
ValueError) with one line naming the problem, quickly and in bounded memory."""

from __future__ import annotations

import io
import os
import time
import tracemalloc
import zipfile

import guitarpro as gp
import pytest

from engine.score import ScoreError, score_to_scene
from engine.score.common import MAX_NOTES

from .helpers import song


def _err(source, match=None, **options) -> str:
    t0 = time.perf_counter()
    with pytest.raises(ScoreError) as info:
        score_to_scene(source, **options)
    assert time.perf_counter() - t0 < 3.0
    msg = str(info.value)
    assert "\n" not in msg and 10 < len(msg) < 400, msg
    assert isinstance(info.value, ValueError)
    if match:
        assert match in msg, msg
    return msg


def _midi_notes(n: int) -> bytes:
    """A one-track MIDI file with n notes (note-on, note-off as velocity 0, running status)."""
    body = b"\x00\x90\x3c\x40" + b"\x60\x3c\x00\x00\x3c\x40" * (n - 1) + b"\x60\x3c\x00"
    body += b"\x00\xff\x2f\x00"
    return (b"MThd" + (6).to_bytes(4, "big") + b"\x00\x00\x00\x01\x01\xe0"
            + b"MTrk" + len(body).to_bytes(4, "big") + body)


def test_empty_and_zero_length(tmp_path):
    _err(b"", "empty")
    p = tmp_path / "nothing.gp5"
    p.write_bytes(b"")
    _err(str(p), "empty")
    _err(io.BytesIO(b""), "empty")


def test_missing_file_and_wrong_types(tmp_path):
    _err(str(tmp_path / "nope.mid"), "cannot read")
    _err(12345, "path, bytes or a binary file")
    with open(tmp_path / "t.txt", "w") as f:
        f.write("x")
    with open(tmp_path / "t.txt") as f:
        _err(f, "text mode")
    _err(b"\x89PNG\r\n\x1a\n" + b"\0" * 100, "not a Guitar Pro (3-8) or Standard MIDI file")
    (tmp_path / "song.gp5").write_bytes(b"hello, I am text pretending to be a tab" * 3)
    _err(str(tmp_path / "song.gp5"), "not a Guitar Pro 3/4/5 file despite its name")
    (tmp_path / "song.mid").write_bytes(b"RIFX" + b"\0" * 40)
    _err(str(tmp_path / "song.mid"), "not a MIDI file despite its name")


def test_zip_renamed_gp5(tmp_path):
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        z.writestr("word/document.xml", "<w/>")
    p = tmp_path / "modern.gp5"
    p.write_bytes(buf.getvalue())
    _err(str(p), "zip archive without Content/score.gpif")
    # a Guitar Pro 7 file renamed .gp5 is read by its content (and this one is empty)
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as z:
        z.writestr("Content/score.gpif", "<GPIF/>")
    p.write_bytes(buf.getvalue())
    _err(str(p), "Guitar Pro file has 0 bars")


def test_bad_options():
    data = song([[[(1, 3, None)]]])
    _err(data, "unknown option", colour="red")
    _err(data, "tempo_scale", tempo_scale=0)
    _err(data, "tempo_scale", tempo_scale="fast")
    _err(data, "max_seconds", max_seconds=-1)
    _err(data, "unknown preset", presets="banjo")
    _err(data, "options.tracks", tracks=[7])


def test_truncated_gp_files():
    data = song([[[(1, 3, None)], [(2, 5, None)], [(3, 7, None)], [(4, 2, None)]]] * 3)
    assert score_to_scene(data).notes
    for cut in (10, 31, 200, len(data) // 2, len(data) - 3):
        msg = _err(data[:cut])
        assert "Guitar Pro" in msg or "header" in msg, msg


def _measure_count_offset(data: bytes) -> int:
    """Where a GP5 file keeps its measure count: just before the track count, which the reader
    has read when it starts on the measure headers."""
    seen = {}

    class Probe(gp.gp5.GP5File):
        def readMeasureHeaders(self, song, measureCount, *args):
            seen["at"] = self.data.tell() - 8
            raise StopIteration

    fp = io.BytesIO(data)
    version = gp.iobase.GPFileBase(fp, "cp1252").readVersion()
    with pytest.raises(StopIteration):
        Probe(fp, "cp1252", version=version, versionTuple=(5, 1, 0)).readSong()
    return seen["at"]


def test_gp_claiming_a_billion_measures():
    data = bytearray(song([[[(1, 3, None)]]]))
    at = _measure_count_offset(bytes(data))
    assert int.from_bytes(data[at:at + 4], "little") == 1
    data[at:at + 4] = (10**9).to_bytes(4, "little")
    _err(bytes(data), "declares 1000000000 measures")
    tracemalloc.start()
    with pytest.raises(ScoreError):
        score_to_scene(bytes(data))
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 20e6
    data[at:at + 4] = (1).to_bytes(4, "little")
    data[at + 4:at + 8] = (10**6).to_bytes(4, "little")
    _err(bytes(data), "declares 1000000 tracks")


def test_midi_with_a_million_notes():
    data = _midi_notes(10**6)
    assert len(data) < 16 * 2**20
    _err(data, f"more than {MAX_NOTES} notes")  # within _err's time limit
    tracemalloc.start()
    with pytest.raises(ScoreError):
        score_to_scene(data)
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert peak < 3 * len(data) + 20e6


def test_small_midi_of_the_same_shape_is_fine():
    scene = score_to_scene(_midi_notes(50), all_instruments=True)
    assert len(scene.notes) == 50


def test_truncated_and_corrupt_midi():
    data = _midi_notes(200)
    for cut in (3, 13, 20, len(data) // 2, len(data) - 2):
        _err(data[:cut], "MIDI")
    bad = bytearray(data)
    bad[8:10] = (7).to_bytes(2, "big")  # format 7
    _err(bytes(bad), "MIDI header is corrupt")
    bad = bytearray(data)
    bad[10:12] = (0).to_bytes(2, "big")  # no tracks
    _err(bytes(bad), "tracks")
    bad = bytearray(data)
    bad[23] = 0x3C  # a data byte where the first status byte should be
    _err(bytes(bad), "MIDI track 1 is corrupt")


def test_oversized_file(tmp_path):
    p = tmp_path / "big.mid"
    with open(p, "wb") as f:
        f.seek(17 * 2**20)
        f.write(b"\0")
    _err(str(p), "limit")


def test_corpus_files_cut_short():
    here = os.path.join(os.path.dirname(__file__), "..", "..", "..", ".cache", "score-corpus")
    files = [os.path.join(here, "gp", "Demo v5.gp5"), os.path.join(here, "midi", "test09.mid")]
    files = [f for f in files if os.path.exists(f)]
    if not files and os.environ.get("CI") == "true":
        pytest.fail("score corpus missing: run `make test-data`")
    for path in files:
        data = open(path, "rb").read()
        for frac in (0.1, 0.5, 0.9):
            _err(data[: int(len(data) * frac)])
